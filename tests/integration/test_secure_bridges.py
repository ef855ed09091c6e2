"""A secured Ciber-Rato run (``iwz run --secure``, the shipped C1 scenario): the legacy bridge is
an identity of its own (``ciberrato``, role bridge), so an unmodified legacy client over real UDP
registers and drives its robot, while a rogue holding a valid agent certificate of the same
authority cannot drive that robot; ``[security] audit = false`` keeps the refusals unlogged."""

from __future__ import annotations

import math
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from lxml import etree

from iw_zenoh import keys
from iw_zenoh.bus import Inbox, ZenohBus
from iw_zenoh.bus.net import NetConfig
from iw_zenoh.errors import DecodeError
from iw_zenoh.messages import ActionBatch, Actions, WorldState, decode, encode
from iw_zenoh.secure.cli import main as secure_main
from iw_zenoh.secure.policy import load_policy
from tests.integration.harness import MAPS, iwz_run_argv, stop_run, subscribe, wait_msg
from tests.integration.legacy import LegacyClient, udp_port

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

SIM = "c1sec"
BACK = -0.15  # the rogue's command: full reverse, which a still robot would show at once


@pytest.fixture
def buses() -> Iterator[list[ZenohBus]]:
    """The test's own sessions (the watcher's, the rogue's), closed after it."""
    made: list[ZenohBus] = []
    yield made
    for b in made:
        b.close()


def _scenario(tmp: Path, port: int, audit: bool) -> Path:
    text = (MAPS / "scenarios" / "ciberrato-c1.toml").read_text().replace("port = 6000", f"port = {port}")
    text = text.replace("duration_s = 250", "duration_s = 600").replace('"../ciberrato/', f'"{MAPS}/ciberrato/')
    sc = tmp / "c1.toml"
    sc.write_text(text + ("" if audit else "\n[security]\naudit = false\n"))
    return sc


def _ids(tmp: Path) -> Path:
    """The run's authority made beforehand, with two identities the scenario does not have: a
    rogue agent (robot 2) and a watcher (a viewer: it reads only)."""
    ids = tmp / "ids"
    assert secure_main(["init", str(ids), "--sim", SIM]) == 0
    assert secure_main(["issue", "rogue", "--role", "agent", "--robots", "2", "--dir", str(ids)]) == 0
    assert secure_main(["issue", "watcher", "--role", "viewer", "--dir", str(ids)]) == 0
    return ids


def _drive(robot: LegacyClient, power: float, cycles: int, rogue: ZenohBus | None = None) -> None:
    """``cycles`` legacy cycles (Measures in, Actions out); the rogue, if any, commands robot 1
    backwards three times a cycle, on its key and in a batch of its own."""
    for _ in range(cycles):
        etree.fromstring(robot.recv()[:-1])
        robot.send(f'<Actions LeftMotor="{power}" RightMotor="{power}"/>'.encode())
        if rogue is not None:
            for _ in range(3):
                rogue.publish(keys.actions(SIM, 1), encode(Actions(robot_id=1, left=BACK, right=BACK)))
            batch = ActionBatch(agent="rogue", actions=[Actions(robot_id=1, left=BACK, right=BACK)])
            rogue.publish(keys.agent_actions(SIM, "rogue"), encode(batch))


def _actions(box: Inbox) -> list[Actions]:
    out = []
    for d in box.drain():
        try:
            out.append(decode(d[1], Actions))
        except DecodeError:
            continue
    return out


def _pose(states: Inbox) -> tuple[float, float]:
    states.drain()
    s = wait_msg(states, WorldState, lambda s: 1 in s.ids)
    i = s.ids.index(1)
    return s.x[i], s.y[i]


@pytest.mark.parametrize(
    ("audit", "option"),
    [(True, False), (False, False), (False, True)],
    ids=["audit", "no-audit", "no-audit-option"],  # the last: `iwz run --no-audit` over the scenario's audit
)
def test_a_legacy_client_drives_its_robot_in_a_secured_run_and_a_rogue_agent_cannot(
    tmp_path: Path, buses: list[ZenohBus], audit: bool, option: bool
) -> None:
    port, ids = udp_port(), _ids(tmp_path)
    logs = tmp_path / "logs"
    extra = ("--secure", "--ids", str(ids), *(["--no-audit"] if option else []))
    argv = iwz_run_argv(_scenario(tmp_path, port, audit or option), logs, SIM, extra=extra)
    endpoint = f"tls/127.0.0.1:{argv[argv.index('--port') + 1]}"
    run = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    robot = LegacyClient(port)
    try:
        reply = robot.register(b'<Robot Id="1" Name="student"/>', tries=60)
        assert etree.fromstring(reply[:-1]).get("Status") == "Ok", reply  # the bridge registered it
        robot.sock.settimeout(10.0)  # a loaded machine's cycle, not croblink's 2 s
        watcher, rogue = (ZenohBus(NetConfig(connect=(endpoint,), identity=str(ids / n))) for n in ("watcher", "rogue"))
        buses += [watcher, rogue]
        states = subscribe(watcher, keys.state(SIM), maxlen=1)
        on_key, batches = subscribe(watcher, keys.actions(SIM, 1)), subscribe(watcher, keys.agent_actions(SIM, "rogue"))
        x0, x1 = _pose(states)[0], -1.0
        for _ in range(10):  # a world held still a while (a verdict late on a loaded machine) goes on after
            _drive(robot, 0.1, 20)
            x1 = _pose(states)[0]
            if x1 > x0 + 0.3:
                break
        assert x1 > x0 + 0.3, (x0, x1)  # the legacy client drives it, through the bridge's identity
        _drive(robot, 0.0, 20)  # at rest (the legacy motors' inertia)
        for _ in range(400):  # until the rogue's session is up and routed (its own key: let through)
            _drive(robot, 0.0, 1, rogue)
            if batches.drain():
                break
        else:
            pytest.fail("the rogue's batches on its own key never arrived in 400 cycles: was it there at all?")
        still = _pose(states)
        _drive(robot, 0.0, 40, rogue)
        there = _pose(states)
        assert math.dist(still, there) < 0.1, (still, there)  # full reverse for 2 s moved it not at all
        assert not [a for a in _actions(on_key) if a.left == BACK], "a rogue's actions reached robot 1's key"
        out, _ = stop_run(run)
    except BaseException:
        for log in sorted(logs.glob("*.log")):  # what each process said, beside the assertion
            print(f"--- {log.name}\n{log.read_text()[-3000:]}")
        raise
    finally:
        robot.close()
        if run.poll() is None:
            print(stop_run(run)[0])
    policy = load_policy(ids / "policy.toml")
    assert list(policy.identities["ciberrato"].roles) == ["bridge", "operator"]
    assert policy.identities["rogue"].robots == [2]
    router = (logs / "router.log").read_text()
    refused = f"access denied: Put from 'rogue' on iw/{SIM}/robot/1/actions"
    if audit:
        assert refused in router, router
    else:
        assert "access denied" not in router, router  # refused all the same (above), but not logged
    assert "Liveliness Token from 'ciberrato'" not in router  # the bridge's name is its identity
    assert "(secured)" in out
