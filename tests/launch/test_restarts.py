from __future__ import annotations

from pathlib import Path

from iw_zenoh.launch.child import Child
from iw_zenoh.launch.restarts import BACKOFF_S, Restarts


def _child(role: str, name: str = "", token: str = "") -> Child:
    return Child(role, name or role, ["x"], Path("x.log"), token=token)


def test_every_role_is_restarted_unless_it_finished_by_itself() -> None:
    r = Restarts()
    for role in ("router", "record", "world", "collision", "sensors", "radio", "bridge", "agent"):
        assert r.restartable(_child(role), -9)
    assert r.restartable(_child("record"), 0)  # a recorder never finishes by itself
    assert not r.restartable(_child("world"), 0)  # its duration reached: the run is over
    assert not r.restartable(_child("agent"), 0)
    assert r.restartable(_child("collision"), 0)


def test_a_child_that_could_not_start_is_not_restarted_but_ends_the_run(tmp_path: Path) -> None:
    r = Restarts()
    agent = _child("agent", "a1", token="a1")
    assert r.could_not_start(agent, 2)  # its arguments or its file refused
    assert r.could_not_start(agent, 1)  # an error before its token was ever seen
    assert not r.could_not_start(agent, 0)
    assert not r.could_not_start(agent, -9)  # killed: restarted as before
    assert agent.owns_token("agent", "a1")
    assert not agent.owns_token("agent", "a2")
    agent.seen = True
    assert r.could_not_start(agent, 3)  # its robot refused
    assert not r.could_not_start(agent, 1)  # it ran: a crash is restarted as before
    agent.restarts = 1
    assert not r.could_not_start(agent, 2)  # a restart that fails is retried as before
    log = tmp_path / "a1.log"
    log.write_text("usage: iwz agent x\niwz agent: no agent program 'x'\n")
    assert Child("agent", "a1", ["x"], log).error() == "iwz agent: no agent program 'x'"


def test_restarts_wait_longer_each_time_and_report_the_time_to_recover() -> None:
    r = Restarts()
    c = _child("sensors", "sensors-1", token="sensors-1-1")
    assert r.due(c, 10.0)  # the first at once
    r.restarted(c)
    assert r.on_alive([c], "sensors", "sensors-2-2", 10.2) == ""  # another shard's token
    assert "sensors-1 is back 0.40 s" in r.on_alive([c], "sensors", "sensors-1-1", 10.4)
    assert list(r.recovered) == ["sensors-1"]
    assert abs(r.recovered["sensors-1"][0] - 0.4) < 1e-9
    assert not r.due(c, 20.0)  # found dead again: the second waits
    assert r.due(c, 20.0 + BACKOFF_S[1])


def test_a_restarted_world_is_handed_the_last_committed_state_in_its_options(tmp_path: Path) -> None:
    import msgspec

    from iw_zenoh.launch.launcher import Launcher
    from iw_zenoh.messages import LabMsg, RobotSpecMsg, WorldInfo, WorldState
    from iw_zenoh.nodes.world_options import WorldOptions
    from iw_zenoh.scenario.file import load_scenario

    maps = Path(__file__).resolve().parents[2] / "maps"
    launcher = Launcher(load_scenario(maps / "scenarios" / "demo.toml"), port=7999, log_dir=tmp_path, status=False)
    launcher.plan()
    world = next(c for c in launcher.children if c.role == "world")
    started: list[bool] = []
    world.start = lambda env: started.append(True)  # type: ignore[method-assign]
    launcher.tally.info = WorldInfo(
        revision=3, lab=LabMsg(name="t", width=40.0, height=20.0), period_ns=100_000_000,
        robots=[RobotSpecMsg(name="slalom", id=1, x_m=10.0, y_m=6.1)],
    )  # fmt: skip
    launcher.tally.on_state(
        WorldState(
            tick=42, revision=3, ids=[1], x=[12.5], y=[6.0], heading=[0.1], collided=[False],
            rolled_left=[0.01], rolled_right=[0.01], speed=[0.1],
        ),
        (),
    )  # fmt: skip
    assert launcher.restarts.due(world, 0.0)
    launcher._restart(world)
    assert started == [True]
    opts = msgspec.json.decode(world.argv[world.argv.index("--options") + 1], type=WorldOptions)
    assert opts.resume is not None
    assert opts.resume.tick == 42
    assert opts.resume.robots[0].pose == (12.5, 6.0, 0.1)
    assert opts.obstacles[0].name == "A"  # the scenario's options are kept beside it
    assert world.restarts == 1


def test_a_world_that_ended_its_run_is_not_taken_for_one_lost(tmp_path: Path) -> None:
    # the world exits 0 at its duration; if it does so between the launcher's look for the run's
    # end and its look for lost roles, the second must leave it to the first (it ended the run
    # with exit 3, "world exited with 0", in a CI run)
    import subprocess
    import sys

    from iw_zenoh.launch.launcher import Launcher
    from iw_zenoh.scenario.file import load_scenario

    maps = Path(__file__).resolve().parents[2] / "maps"
    launcher = Launcher(load_scenario(maps / "scenarios" / "demo.toml"), port=7999, log_dir=tmp_path, status=False)
    launcher.plan()
    world = next(c for c in launcher.children if c.role == "world")
    world.proc = subprocess.Popen([sys.executable, "-c", "pass"])
    assert world.proc.wait(60) == 0
    world.seen = True
    assert launcher._restart_lost() is None
    assert launcher._ended(None, world) == 0  # type: ignore[arg-type]  # the run's end, found on the next pass
