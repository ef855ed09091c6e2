"""``iwz render FILE --at T [--window S] [--robot ID] -o PNG``: a picture of a moment.

Left: the map, every body at T, the trajectories over the window before T, the proximity cones
of every robot at T drawn to their readings, and a marker on every incident of the window.
Right (with ``--robot``): that robot's speed, motor commands and nearest-obstacle distance over
the window.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path
from typing import IO

import matplotlib

matplotlib.use("Agg")  # files only, no screen
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Polygon as PatchPolygon  # noqa: E402
from matplotlib.patches import Wedge  # noqa: E402
from mcap.reader import make_reader  # noqa: E402

from iw_zenoh import keys  # noqa: E402
from iw_zenoh.convert import spec_from_msg  # noqa: E402
from iw_zenoh.core.bodies import Bodies  # noqa: E402
from iw_zenoh.errors import DecodeError, IwError  # noqa: E402
from iw_zenoh.messages import (  # noqa: E402
    ActionBatch,
    Actions,
    CollisionData,
    Event,
    EventKind,
    SensorReading,
    WorldInfo,
    WorldState,
    decode,
    event_payload,
)

__all__ = ["main", "render"]

INCIDENTS = (
    EventKind.COLLISION,
    EventKind.WATCHDOG,
    EventKind.AGENT_LOST,
    EventKind.HOLDING,
    EventKind.REFUSED,
    EventKind.LAGGARD,
)


def render(f: IO[bytes], out: Path, *, at_s: float, window_s: float = 10.0, robot: int | None = None) -> int:
    """Draws the moment ``at_s`` (simulation seconds) of a recording to a PNG.

    Returns:
        The tick drawn.

    Raises:
        IwError: When the recording has no world description or no state near ``at_s``.
    """
    at = int(at_s * 1e9)
    lo = at - int(window_s * 1e9)
    info: WorldInfo | None = None
    track: dict[int, list[tuple[float, float]]] = {}
    series: dict[str, list[tuple[float, float]]] = {"speed": [], "left": [], "right": [], "nearest": []}
    state: WorldState | None = None
    readings: dict[int, SensorReading] = {}
    events: list[Event] = []
    for _, ch, msg in make_reader(f).iter_messages():
        kind = keys.topic_kind(ch.topic)
        try:
            if kind == "info":
                info = decode(msg.data, WorldInfo) if msg.publish_time <= at or info is None else info
                continue
            if msg.publish_time < lo or msg.publish_time > at:
                continue
            t = msg.publish_time / 1e9
            if kind == "state":
                s = decode(msg.data, WorldState)
                state = s
                for rid, x, y in zip(s.ids, s.x, s.y, strict=True):
                    track.setdefault(rid, []).append((x, y))
                if robot is not None and robot in s.ids:
                    series["speed"].append((t, s.speed[s.ids.index(robot)]))
            elif kind == "sensors":
                r = decode(msg.data, SensorReading)
                readings[r.robot_id] = r
                if r.robot_id == robot:
                    near = [d for d in r.proximity_m if d is not None]
                    series["nearest"].append((t, min(near) if near else math.nan))
            elif kind in ("actions", "action_batch") and robot is not None:
                acts = [decode(msg.data, Actions)] if kind == "actions" else decode(msg.data, ActionBatch).actions
                for a in acts:
                    if a.robot_id == robot:
                        series["left"].append((t, a.left))
                        series["right"].append((t, a.right))
            elif kind == "event":
                e = decode(msg.data, Event)
                if e.kind in INCIDENTS:
                    events.append(e)
        except IwError:
            continue
    if info is None:
        raise IwError("the recording holds no world description (iw/SIM/world/info)")
    if state is None:
        raise IwError(f"no world state between {lo / 1e9:g} s and {at_s:g} s in this recording")
    cols = 2 if robot is not None else 1
    fig, axes = plt.subplots(
        1, cols, figsize=(8 * cols, 8 * info.lab.height / max(info.lab.width, 1e-9) + 1.5), squeeze=False
    )
    ax = axes[0][0]
    ax.set_title(f"{info.lab.name}: t = {state.sim_time_ns / 1e9:.1f} s (tick {state.tick})")
    ax.add_patch(
        PatchPolygon(
            [(0, 0), (info.lab.width, 0), (info.lab.width, info.lab.height), (0, info.lab.height)], fill=False, lw=2
        )
    )
    for w in info.lab.walls:
        ax.add_patch(PatchPolygon(w.corners, closed=True, color="0.35"))
    specs = {s.id: spec_from_msg(s) for s in info.robots}
    ids = [i for i in state.ids if i in specs]
    if ids:
        idx = [state.ids.index(i) for i in ids]
        pose = np.column_stack([np.asarray(state.x)[idx], np.asarray(state.y)[idx], np.asarray(state.heading)[idx]])
        bodies = Bodies.from_specs([specs[i] for i in ids])
        outline = bodies.world_outline(pose)
        cmap = plt.get_cmap("tab10")
        for k, rid in enumerate(ids):
            color = cmap(k % 10)
            hit = state.collided[idx[k]]
            ax.add_patch(PatchPolygon(outline[k], closed=True, color="red" if hit else color, alpha=0.8))
            path = np.asarray(track.get(rid, []))
            if len(path):
                ax.plot(path[:, 0], path[:, 1], "-", color=color, lw=1)
            ax.annotate(str(rid), pose[k, :2], ha="center", va="center", fontsize=8, color="white")
            rd = readings.get(rid)
            if rd is None:
                continue
            sel = np.flatnonzero(bodies.ir_owner == k)
            for m, dist in zip(sel, rd.proximity_m, strict=False):
                cos_h, sin_h = math.cos(pose[k, 2]), math.sin(pose[k, 2])
                lx, ly = bodies.ir_xy[m]
                ox, oy = pose[k, 0] + cos_h * lx - sin_h * ly, pose[k, 1] + sin_h * lx + cos_h * ly
                phi = math.degrees(pose[k, 2] + bodies.ir_angle_rad[m])
                half = math.degrees(bodies.ir_half_cone_rad[m])
                reach = float(bodies.ir_range_m[m]) if dist is None else float(dist)
                ax.add_patch(
                    Wedge(
                        (ox, oy), reach, phi - half, phi + half, color=color, alpha=0.12 if dist is None else 0.3, lw=0
                    )
                )
    for e in events:
        if e.kind == EventKind.COLLISION:
            try:
                place = event_payload(e, CollisionData)
                ax.plot([place.x], [place.y], "rx", ms=14, mew=3)
            except DecodeError:
                pass  # no place to mark
        ax.text(
            0.01,
            0.01 + 0.03 * events.index(e),
            f"{e.sim_time_ns / 1e9:.1f} s {e.kind}: {e.reason}"[:90],
            transform=ax.transAxes,
            fontsize=7,
            color="red",
        )
    ax.set_xlim(-0.5, info.lab.width + 0.5)
    ax.set_ylim(-0.5, info.lab.height + 0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if robot is not None:
        ax2 = axes[0][1]
        ax2.set_title(f"robot {robot}, {window_s:g} s up to t = {at_s:g} s")
        for name, label in (
            ("speed", "speed (m/s)"),
            ("left", "left power"),
            ("right", "right power"),
            ("nearest", "nearest obstacle (m)"),
        ):
            pts = np.asarray(series[name]) if series[name] else np.zeros((0, 2))
            if len(pts):
                ax2.plot(pts[:, 0], pts[:, 1], label=label)
        ax2.set_xlabel("simulation time (s)")
        ax2.legend(loc="upper left")
        ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return state.tick


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz render``."""
    p = argparse.ArgumentParser(
        prog="iwz render",
        description="Draw a moment of a recording (map, bodies, trajectories, cones, incidents) to PNG.",
    )
    p.add_argument("file", help="MCAP recording")
    p.add_argument("--at", type=float, required=True, help="simulation time to draw, s")
    p.add_argument(
        "--window",
        type=float,
        default=10.0,
        help="trajectories and plots over this many seconds before --at (default 10)",
    )
    p.add_argument("--robot", type=int, help="also plot this robot's speed, commands and nearest-obstacle distance")
    p.add_argument("-o", "--output", required=True, help="PNG file to write")
    args = p.parse_args(argv)
    try:
        with Path(args.file).open("rb") as f:
            tick = render(f, Path(args.output), at_s=args.at, window_s=args.window, robot=args.robot)
    except (OSError, IwError) as e:
        print(f"iwz render: {e}")
        return 2
    print(f"iwz render: tick {tick} drawn to {args.output}")
    return 0
