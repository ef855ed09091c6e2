"""A world description forged on ``world/info`` before the world is restarted does not become the
restarted world's roster: ``iwz run`` keeps only descriptions sealed by the world it started."""

from __future__ import annotations

import re
import subprocess
import time
from pathlib import Path

import msgspec
import pytest

from iw_zenoh import keys
from iw_zenoh.messages import WorldInfo, WorldState, decode, encode
from tests.integration.faults import FaultRun as _Run
from tests.integration.faults import fault_scenario as _scenario
from tests.integration.harness import wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(170)]


def test_a_forged_world_description_before_a_world_restart_does_not_empty_the_restarted_world(tmp_path: Path) -> None:
    run = _Run(_scenario(tmp_path, duration_s=40), tmp_path)
    try:
        run.wait_moving(timeout_s=60)
        [data] = run.bus.query(keys.info(run.sim), timeout_s=10)
        info = decode(data, WorldInfo)
        assert isinstance(info.seal, str)  # the world seals what it says for its iwz run
        forged = msgspec.structs.replace(
            info, revision=info.revision + 1000, robots=[], agents=[], obstacles=[], seal=msgspec.UNSET
        )
        stolen = msgspec.structs.replace(forged, seal=info.seal)  # a seal copied from another description
        for payload in (encode(forged), encode(stolen)):
            run.bus.publish(keys.info(run.sim), payload)
        # the launcher looks at what came every 0.1 s: ten ticks on, it has taken them in
        now = wait_msg(run.states, WorldState, lambda m: 1 in m.ids, timeout_s=20)
        wait_msg(run.states, WorldState, lambda m: m.tick > now.tick + 10, timeout_s=20)
        subprocess.run(["kill", "-KILL", str(run.pid("world"))], check=True, timeout=10)
        run.wait_token("world", since=time.monotonic() - 0.05)
        code, out = run.finish(timeout_s=90)
    finally:
        run.close()
    world_log = (tmp_path / "logs" / "world.log").read_text(errors="replace")
    resumed = re.findall(r"resuming at tick \d+ with (\d+) robots", world_log)
    assert resumed == ["1"], world_log[-2000:]  # was: 'with 0 robots', its chair gone
    assert "a world description not from the world iwz run started was ignored" in out
    assert code == 0, out
