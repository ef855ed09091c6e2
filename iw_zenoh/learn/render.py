"""A learning environment's picture (``render_mode="rgb_array"``): walls, chairs, goals."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from matplotlib.patches import Polygon as PatchPolygon

from iw_zenoh.core.lab import Lab
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.learn.nav import Goal
from iw_zenoh.messages import WorldState

__all__ = ["frame"]


def _body(spec: RobotSpec, x: float, y: float, h: float) -> list[tuple[float, float]]:
    front, rear, half = spec.width_m * spec.com, -spec.width_m * (1 - spec.com), spec.height_m / 2
    c, s = math.cos(h), math.sin(h)
    return [
        (x + c * u - s * v, y + s * u + c * v) for u, v in ((rear, -half), (front, -half), (front, half), (rear, half))
    ]


def frame(
    lab: Lab, state: WorldState, specs: Mapping[int, RobotSpec], goals: Mapping[int, Goal], px: int = 400
) -> np.ndarray:
    """An ``(H, W, 3)`` ``uint8`` picture of the world, ``px`` pixels across its longer side."""
    scale = px / max(lab.width_m, lab.height_m)
    fig = Figure(figsize=(lab.width_m * scale / 100, lab.height_m * scale / 100), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, lab.width_m)
    ax.set_ylim(0, lab.height_m)
    ax.set_axis_off()
    for w in lab.walls:
        ax.add_patch(PatchPolygon(w.corners, closed=True, color="0.3"))
    for g in goals.values():
        ax.add_patch(Circle((g.x, g.y), g.within, color="tab:green", alpha=0.5))
    for i, rid in enumerate(state.ids):
        spec = specs.get(rid)
        if spec is None:
            continue
        color = "tab:red" if state.collided[i] else ("tab:blue" if rid in goals else "tab:orange")
        ax.add_patch(PatchPolygon(_body(spec, state.x[i], state.y[i], state.heading[i]), closed=True, color=color))
    canvas = FigureCanvasAgg(fig)
    canvas.draw()  # type: ignore[no-untyped-call]
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()  # type: ignore[no-untyped-call]
