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
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PatchPolygon
from matplotlib.patches import Wedge

from iw_zenoh.convert import spec_from_msg
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.errors import DecodeError, IwError
from iw_zenoh.messages import (
    ActionBatch,
    Actions,
    CollisionData,
    Event,
    EventKind,
    SensorReading,
    WorldInfo,
    WorldState,
    event_payload,
)
from iw_zenoh.record.reader import RecordingReader, discard_cut_off, file_error, open_recording, print_notes

__all__ = ["main", "render"]

INCIDENTS = (
    EventKind.COLLISION,
    EventKind.WATCHDOG,
    EventKind.AGENT_LOST,
    EventKind.HOLDING,
    EventKind.REFUSED,
    EventKind.LAGGARD,
)
KINDS = ("info", "state", "sensors", "event")  # what a picture is drawn from
ROBOT_KINDS = ("actions", "action_batch")  # and, for one robot's plots, its commands


@dataclass
class _Moment:
    """What a recording holds about the window before one moment."""

    info: WorldInfo | None = None
    state: WorldState | None = None
    track: dict[int, list[tuple[float, float]]] = field(default_factory=dict)
    series: dict[str, list[tuple[float, float]]] = field(
        default_factory=lambda: {"speed": [], "left": [], "right": [], "nearest": []}
    )
    readings: dict[int, SensorReading] = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)


def _collect(rec: RecordingReader, at: int, lo: int, robot: int | None) -> _Moment:
    """The world description, the last state, tracks, readings, incidents and one robot's series."""
    m = _Moment()
    for r in rec.records(KINDS if robot is None else KINDS + ROBOT_KINDS):
        msg = r.message
        if isinstance(msg, WorldInfo):
            m.info = msg if r.publish_time <= at or m.info is None else m.info
            continue
        if r.publish_time < lo or r.publish_time > at:
            continue
        t = r.publish_time / 1e9
        if isinstance(msg, WorldState):
            m.state = msg
            for rid, x, y in zip(msg.ids, msg.x, msg.y, strict=True):
                m.track.setdefault(rid, []).append((x, y))
            if robot is not None and robot in msg.ids:
                m.series["speed"].append((t, msg.speed[msg.ids.index(robot)]))
        elif isinstance(msg, SensorReading):
            m.readings[msg.robot_id] = msg
            if msg.robot_id == robot:
                near = [d for d in msg.proximity_m if d is not None]
                m.series["nearest"].append((t, min(near) if near else math.nan))
        elif isinstance(msg, Actions | ActionBatch):
            for a in [msg] if isinstance(msg, Actions) else msg.actions:
                if a.robot_id == robot:
                    m.series["left"].append((t, a.left))
                    m.series["right"].append((t, a.right))
        elif isinstance(msg, Event) and msg.kind in INCIDENTS:
            m.events.append(msg)
    return m


def render(
    f: IO[bytes] | RecordingReader, out: Path, *, at_s: float, window_s: float = 10.0, robot: int | None = None
) -> int:
    """Draws the moment ``at_s`` (simulation seconds) of a recording to a PNG.

    Args:
        f: The recording (a stream, or a reader over one).
        out: The PNG to write.
        at_s: The moment, simulation seconds.
        window_s: Trajectories and plots over this many seconds before it.
        robot: Also plot this robot's speed, commands and nearest-obstacle distance.

    Returns:
        The tick drawn.

    Raises:
        IwError: When the recording has no world description or no state near ``at_s``, or
            cannot be read (``RecordingError``).
    """
    at = int(at_s * 1e9)
    lo = at - int(window_s * 1e9)
    m = _collect(f if isinstance(f, RecordingReader) else RecordingReader(f), at, lo, robot)
    info, state = m.info, m.state
    if info is None:
        raise IwError("the recording holds no world description (iw/SIM/world/info)")
    if state is None:
        raise IwError(f"no world state between {lo / 1e9:g} s and {at_s:g} s in this recording")
    cols = 2 if robot is not None else 1
    fig = Figure(figsize=(8 * cols, 8 * info.lab.height / max(info.lab.width, 1e-9) + 1.5))
    FigureCanvasAgg(fig)  # files only, no screen: the Agg canvas, whatever pyplot's backend is
    axes = fig.subplots(1, cols, squeeze=False)
    _draw_world(axes[0][0], info, state, m)
    if robot is not None:
        _draw_series(axes[0][1], m.series, robot=robot, at_s=at_s, window_s=window_s)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    return state.tick


def _draw_world(ax: Axes, info: WorldInfo, state: WorldState, m: _Moment) -> None:
    """The map, every body, its track and its cones, and the incidents of the window."""
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
        cmap = mpl.colormaps["tab10"]
        for k, rid in enumerate(ids):
            color = cmap(k % 10)
            hit = state.collided[idx[k]]
            ax.add_patch(PatchPolygon(outline[k], closed=True, color="red" if hit else color, alpha=0.8))
            path = np.asarray(m.track.get(rid, []))
            if len(path):
                ax.plot(path[:, 0], path[:, 1], "-", color=color, lw=1)
            ax.annotate(str(rid), (pose[k, 0], pose[k, 1]), ha="center", va="center", fontsize=8, color="white")
            rd = m.readings.get(rid)
            if rd is not None:
                _draw_cones(ax, bodies, k, pose[k], rd, color)
    for e in m.events:
        if e.kind == EventKind.COLLISION:
            try:
                place = event_payload(e, CollisionData)
                ax.plot([place.x], [place.y], "rx", ms=14, mew=3)
            except DecodeError:
                pass  # no place to mark
        ax.text(
            0.01,
            0.01 + 0.03 * m.events.index(e),
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


def _draw_cones(ax: Axes, bodies: Bodies, k: int, pose: np.ndarray, rd: SensorReading, color: object) -> None:
    """Body ``k``'s proximity cones, each drawn to its reading (to its range when it sees nothing)."""
    sel = np.flatnonzero(bodies.ir_owner == k)
    for m, dist in zip(sel, rd.proximity_m, strict=False):
        cos_h, sin_h = math.cos(pose[2]), math.sin(pose[2])
        lx, ly = bodies.ir_xy[m]
        ox, oy = pose[0] + cos_h * lx - sin_h * ly, pose[1] + sin_h * lx + cos_h * ly
        phi = math.degrees(pose[2] + bodies.ir_angle_rad[m])
        half = math.degrees(bodies.ir_half_cone_rad[m])
        reach = float(bodies.ir_range_m[m]) if dist is None else float(dist)
        ax.add_patch(
            Wedge((ox, oy), reach, phi - half, phi + half, color=color, alpha=0.12 if dist is None else 0.3, lw=0)
        )


def _draw_series(
    ax: Axes, series: dict[str, list[tuple[float, float]]], *, robot: int, at_s: float, window_s: float
) -> None:
    """One robot's speed, motor commands and nearest-obstacle distance over the window."""
    ax.set_title(f"robot {robot}, {window_s:g} s up to t = {at_s:g} s")
    for name, label in (
        ("speed", "speed (m/s)"),
        ("left", "left power"),
        ("right", "right power"),
        ("nearest", "nearest obstacle (m)"),
    ):
        pts = np.asarray(series[name]) if series[name] else np.zeros((0, 2))
        if len(pts):
            ax.plot(pts[:, 0], pts[:, 1], label=label)
    ax.set_xlabel("simulation time (s)")
    ax.legend(loc="upper left")
    ax.grid(True, alpha=0.3)


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
        with open_recording(args.file) as rec:
            tick = render(rec, Path(args.output), at_s=args.at, window_s=args.window, robot=args.robot)
            print_notes("iwz render", rec)
    except (OSError, IwError) as e:
        discard_cut_off(args.output, e)
        print(f"iwz render: {file_error(args.file, e, output=args.output)}")
        return 2
    print(f"iwz render: tick {tick} drawn to {args.output}")
    return 0
