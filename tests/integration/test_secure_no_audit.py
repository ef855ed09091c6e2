"""``iwz router --no-audit``: the policy is still enforced, but refusals are not logged (the
router does not read Zenoh's per-message access-control log; docs/security.md gives the cost)."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.bus import Inbox, ZenohBus
from iw_zenoh.bus.net import NetConfig
from iw_zenoh.messages import Actions, Control, encode
from iw_zenoh.secure.certs import init_ca, issue
from iw_zenoh.secure.cli import add_identity
from tests.integration.harness import Net

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(120)]

MARK = Actions(robot_id=2, left=0.0, right=0.0)


def test_a_router_without_audit_still_refuses_but_does_not_log(tmp_path: Path) -> None:
    ids = tmp_path / "ids"
    init_ca(ids)
    issue(ids, "router", server=True)
    for name, role, robots in (("world", "world", ()), ("rogue", "agent", (2,))):
        issue(ids, name)
        add_identity(ids / "policy.toml", name, [role], robots=robots)
    net = Net(tmp_path, sim="default")
    try:
        router = net.start_secured_router(ids, "--no-audit")
        endpoint = net.endpoint
        world, rogue = (ZenohBus(NetConfig(connect=(endpoint,), identity=str(ids / n))) for n in ("world", "rogue"))
        net.buses += [world, rogue]
        controls, actions = Inbox(), Inbox()
        world.subscribe(keys.control("default"), controls)
        world.subscribe(keys.actions("default", 2), actions)
        deadline = time.monotonic() + 20
        while actions.get(timeout_s=0.2) is None:  # the rogue's own robot: allowed, once routes are up
            assert time.monotonic() < deadline, f"the rogue's allowed actions never arrived:\n{router.output()}"
            for _ in range(5):
                rogue.publish(keys.control("default"), encode(Control(command="stop")))
            rogue.publish(keys.actions("default", 2), encode(MARK))
        for _ in range(25):  # what the audited router reports within milliseconds (test_secure.py)
            rogue.publish(keys.control("default"), encode(Control(command="stop")))
            time.sleep(0.02)  # a sender's pace, not synchronisation
        rogue.publish(keys.actions("default", 2), encode(MARK))
        assert actions.get(timeout_s=10) is not None
        assert not controls.drain(), "a refused control message reached the world"
        end = time.monotonic() + 1.0  # 50 times the audited router's batching delay
        while time.monotonic() < end:
            assert "access denied" not in router.output()
            time.sleep(0.1)  # polling a log file: there is no event to wait on
    finally:
        net.close()
