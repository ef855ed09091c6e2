"""The ``iwz`` command: one subcommand per process role and per tool.

iwz run demo                  the whole simulation (a shipped scenario), every role its own process
iwz router | world MAP | collision | sensors | radio | agent NAME
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Sequence

__all__ = ["COMMANDS", "main"]

EXIT_PIPE_CLOSED = 141  # 128 + SIGPIPE: how a shell tool ends when its reader goes away

COMMANDS: dict[str, tuple[str, str] | tuple[str, str, str]] = {
    "run": (
        "iw_zenoh.launch.launcher",
        "start a scenario: router, world, collision, sensors, radio and agents, supervised",
    ),
    "scenarios": ("iw_zenoh.scenario.shipped", "the scenarios that ship: list them, copy one to start your own"),
    "router": ("iw_zenoh.nodes.router", "the Zenoh router the other processes connect to"),
    "world": ("iw_zenoh.nodes.world", "the world: clock, motors, kinematics, registration"),
    "collision": ("iw_zenoh.nodes.collision", "collision verdicts on every tick's proposed poses"),
    "sensors": ("iw_zenoh.nodes.sensors", "every robot's sensors each tick (shardable)"),
    "radio": ("iw_zenoh.nodes.radio", "robot-to-robot messages within range"),
    "agent": ("iw_zenoh.nodes.agents", "run agent programs (wanderer, waypoint, ...)"),
    "ros2": ("iw_zenoh.nodes.ros2", "chairs a ROS 2 stack drives: odom, scan, /tf, /clock, cmd_vel on rmw_zenoh keys"),
    "bridge": (
        "iw_zenoh.bridges.dispatch",
        "bridges: `iwz bridge ciberrato` (legacy XML/UDP agents and viewers), `iwz bridge serial` (a real chair)",
    ),
    "chair": ("iw_zenoh.bridges.serial.emulator", "`iwz chair emulate`: a chair board on a pseudo-terminal"),
    "ctl": ("iw_zenoh.nodes.ctl", "steer a running simulation: pause, resume, step, stop, remove, obstacles"),
    "foxglove": ("iw_zenoh.nodes.foxglove_live", "serve a running simulation to Foxglove / Lichtblick (WebSocket)"),
    "view": (
        "iw_zenoh.nodes.viewer",
        "the web viewer: 2D and 3D of a live run, steered from the page, or a recording with a timeline",
    ),
    "secure": ("iw_zenoh.secure.cli", "identities: a certificate authority, a certificate per process, the policy"),
    "record": ("iw_zenoh.nodes.recorder", "record every key of a simulation to MCAP"),
    "replay": ("iw_zenoh.nodes.replay", "play a recording back into Zenoh (rate, window, loop, seek)"),
    "incidents": ("iw_zenoh.record.incidents", "list a recording's collisions, near misses, stops and losses"),
    "report": ("iw_zenoh.record.report", "what a study measures of a run (or two side by side): table, JSON, HTML"),
    "render": ("iw_zenoh.record.render", "draw a moment of a recording to PNG (map, bodies, cones, plots)"),
    "resim": ("iw_zenoh.record.resim", "re-run a lock-step recording exactly; swap one robot's agent"),
    "calibrate": ("iw_zenoh.record.calibrate", "fit MaxSpeed and AccelerationCurve to a real chair's log"),
    "export": ("iw_zenoh.record.ros2_export", "a recording as a rosbag2 bag ROS 2 tools read (--ros2)"),
    "doctor": ("iw_zenoh.record.tools", "say whether a recording is whole", "doctor_main"),
    "recover": ("iw_zenoh.record.tools", "rebuild a readable, indexed file from a cut-off recording", "recover_main"),
}


def usage() -> str:
    """The top-level help."""
    width = max(len(c) for c in COMMANDS)
    lines = [
        "usage: iwz COMMAND [options]",
        "",
        "iw-zenoh: an intelligent-wheelchair simulator whose every part is its own process on Eclipse Zenoh.",
        "",
        "commands:",
    ]
    lines += [f"  {c:<{width}}  {e[1]}" for c, e in COMMANDS.items()]
    lines += ["", "Each command has --help. Start here: iwz scenarios, then iwz run demo"]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Dispatches to a subcommand's ``main``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help", "help"):
        print(usage())
        return 0 if args else 2
    if args[0] in ("-V", "--version"):
        from iw_zenoh import __version__

        print(f"iwz {__version__}")
        return 0
    entry = COMMANDS.get(args[0])
    if entry is None:
        print(f"iwz: unknown command {args[0]!r}\n\n{usage()}")
        return 2
    module = importlib.import_module(entry[0])
    func = getattr(module, entry[2] if len(entry) > 2 else "main")
    try:
        code: int = func(args[1:])
        sys.stdout.flush()
    except BrokenPipeError:  # `iwz incidents x.mcap | head -1`: the reader has all it wants
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # nothing more to flush at exit
        return EXIT_PIPE_CLOSED
    return code


if __name__ == "__main__":
    raise SystemExit(main())
