"""A one-chair agent process loads only what its program uses (issue #23): its start-up path, run
in a fresh interpreter, imports no compiled kernels, plotting, geometry, recording or viewer code.

Each case runs ``iwz agent PROGRAM``'s own path (find the program, parse its options, make its
agents, put their spec on the wire, answer one tick) in a subprocess and reads ``sys.modules``:
a new top-level import anywhere on that path makes it fail, naming what came in.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from iw_zenoh.agent.programs import available

# what a light agent must never load: compiled kernels, plotting, geometry, XML maps, recording, viewer
HEAVY = ("numba", "llvmlite", "matplotlib", "shapely", "scipy", "lxml", "mcap", "aiohttp", "foxglove")

START_UP = """
import argparse, json, sys
from iw_zenoh.nodes import agents  # what `iwz agent` imports
from iw_zenoh.agent.programs import add_spec_arguments, find_program, make_with_spec
from iw_zenoh.convert import spec_to_msg
from iw_zenoh.messages import SensorReading, encode

program = find_program(sys.argv[1])
parser = argparse.ArgumentParser()
program.add_arguments(parser)
add_spec_arguments(parser)
args = parser.parse_args(sys.argv[2:])
made = make_with_spec(program, args)
for agent in made:
    encode(spec_to_msg(agent.spec()))
    reading = SensorReading(
        robot_id=1, tick=1, sim_time_ns=100_000_000, proximity_ids=[], proximity_m=[],
        proximity_legacy=[], compass_deg=0.0, gps=(1.0, 1.0, 0.0),
    )
    agent.on_sensors(reading, [])
print(json.dumps({"agents": len(made), "modules": sorted(sys.modules)}))
"""

PROGRAMS = [
    ("waypoint", ["--waypoints", "16,5.55;21.5,6.5", "--id", "1"]),
    ("convoy", ["--role", "follower", "--id", "3", "--follow", "4"]),
    ("door", ["--kind", "hinged", "--at", "10,5.5,-90"]),
]


def _start_up(program: str, options: list[str]) -> tuple[int, set[str]]:
    done = subprocess.run(
        [sys.executable, "-c", START_UP, program, *options], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    return out["agents"], {m.split(".")[0] for m in out["modules"]}


@pytest.mark.parametrize(("program", "options"), PROGRAMS, ids=[p for p, _ in PROGRAMS])
def test_a_light_agent_process_loads_no_kernels_plotting_geometry_or_viewer(program: str, options: list[str]) -> None:
    made, loaded = _start_up(program, options)
    assert made >= 1
    assert sorted(loaded.intersection(HEAVY)) == []
    assert "zenoh" in loaded  # the path really is the agent's: it talks over Zenoh


def test_an_agent_process_imports_no_other_program() -> None:
    script = (
        "import sys\n"
        "from iw_zenoh.agent.programs import find_program\n"
        "find_program('waypoint')\n"
        "print(' '.join(m.rsplit('.', 1)[1] for m in sys.modules if m.startswith('iw_zenoh.agents.')))"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    loaded = set(done.stdout.split())
    others = set(available()) - {"waypoint"}  # every other program (helper modules it imports may come)
    assert "waypoint" in loaded
    assert sorted(loaded & others) == []


WORLD_TICK = """
import json, sys
from iw_zenoh.nodes import world  # what `iwz world` imports
from iw_zenoh.core.lab import Grid, GridPosition, Lab
from iw_zenoh.messages import Proposed, RegisterRequest, RobotSpecMsg, Verdict
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.world import WorldCore

core = WorldCore(WorldConfig(sim="t"), Lab("t", 20.0, 10.0, ()), Grid((GridPosition(2, 5, 0),)))
reply, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
assert reply.ok, reply.reason
for n in range(3):
    prop = next(m for _, m in core.begin_tick(n * 100_000_000) if isinstance(m, Proposed))
    core.finish_tick(Verdict(tick=prop.tick, revision=prop.revision, ids=prop.ids, collided=[False]))
print(json.dumps(sorted(sys.modules)))
"""


def test_the_world_process_steps_with_its_drive_kernel_and_without_the_collision_kernel() -> None:
    # the world loads numba for its own kernel: its propose and commit are compiled
    # (iw_zenoh.core.drive, issue #36), the one implementation the in-process world runs too;
    # the compiled contact test stays the collision role's (the world holds its verdicts), and
    # plotting, recording and the viewer stay out (issue #23's memory budget)
    done = subprocess.run([sys.executable, "-c", WORLD_TICK], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    modules = set(json.loads(done.stdout.strip().splitlines()[-1]))
    loaded = {m.split(".")[0] for m in modules}
    assert "iw_zenoh.core.drive" in modules
    assert "numba" in loaded
    assert sorted(modules & {"iw_zenoh.core.contact", "iw_zenoh.core.placing", "iw_zenoh.core.cones"}) == []
    assert sorted(loaded.intersection({"matplotlib", "mcap", "aiohttp", "foxglove"})) == []
