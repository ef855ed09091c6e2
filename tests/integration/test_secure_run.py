"""``iwz run --secure`` (issue 20): a scenario run to its verdict with every process holding an
identity of its own, on one machine, and across two hosts (two network namespaces joined by a
veth pair, private addresses only), all traffic TLS."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from iw_zenoh.record.reader import RecordingReader
from iw_zenoh.secure.policy import load_policy
from tests.integration import netns
from tests.integration.harness import iwz_run_argv, stop_run

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(300)]

LAB = '<Lab Name="open" Width="20" Height="10"/>'
GRID = '<Grid><Position X="3" Y="5" Dir="0"/><Position X="3" Y="8" Dir="0"/></Grid>'
SCENARIO = """
name = "secured"
[world]
map = "lab.xml"
grid = "grid.xml"
mode = "lockstep"
duration_s = 4
[roles]
radio = true
[[agents]]
name = "driver"
program = "waypoint"
args = ["--id", "1", "--waypoints", "9,5"]
[criteria]
max_collisions = 0
{security}
"""


def _scenario(tmp: Path, security: str = "") -> Path:
    (tmp / "lab.xml").write_text(LAB)
    (tmp / "grid.xml").write_text(GRID)
    sc = tmp / "secured.toml"
    sc.write_text(SCENARIO.format(security=security))
    return sc


def _finish(p: subprocess.Popen[str], timeout_s: float) -> tuple[int, str]:
    try:
        out, err = p.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        out, err = stop_run(p)
        pytest.fail(f"still running after {timeout_s:g} s, stopped:\n{out}{err}")
    return p.returncode, (out or "") + (err or "")


def test_a_secured_run_reaches_its_verdict_with_an_identity_per_process(tmp_path: Path) -> None:
    sc = _scenario(tmp_path)
    logs = tmp_path / "logs"
    argv = iwz_run_argv(sc, logs, "sr", record=tmp_path / "run.mcap", extra=("--secure",))
    code, out = _finish(subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True), 240)
    assert code == 0, out
    assert re.search(r"ended at t=4\.0 s \(tick 40\), 1 robots", out), out
    assert "(secured)" in out
    assert "PASS collisions 0" in out
    policy = load_policy(logs / "ids" / "policy.toml")
    assert policy.sim == "sr"
    assert policy.identities["driver"].robots == [1]
    assert {"world", "collision", "sensors-1-1", "radio", "recorder", "launcher"} <= set(policy.identities)
    assert "access denied" not in (logs / "router.log").read_text()  # every role did only what it may
    with (tmp_path / "run.mcap").open("rb") as f:
        kinds = {r.kind for r in RecordingReader(f).raw()}
    assert {"state", "tick", "actions"} <= kinds  # the recorder, a reader, was sent everything


@pytest.fixture
def two_hosts() -> Iterator[tuple[str, str, str]]:
    """Two namespaces joined by a veth pair: yields (ns_a, ns_b, address of a); always removed."""
    with netns.two_hosts("s", "10.232.100") as hosts:
        yield hosts


def test_a_secured_run_split_across_two_hosts_reaches_its_verdict(
    two_hosts: tuple[str, str, str], tmp_path: Path
) -> None:
    ns_a, ns_b, addr = two_hosts
    sc = _scenario(tmp_path, '[security]\nhosts = { b = ["collision", "sensors-1", "driver"] }')
    ids = tmp_path / "ids"
    run = [
        sys.executable,
        "-m",
        "iw_zenoh.cli",
        "run",
        str(sc),
        "--no-status",
        "--no-record",
        "--sim",
        "mh",
        "--ids",
        str(ids),
    ]
    a = subprocess.Popen(
        ["ip", "netns", "exec", ns_a, *run, "--listen", f"tls/{addr}:7447", "--log-dir", str(tmp_path / "a")],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    b: subprocess.Popen[str] | None = None
    try:
        router_log = tmp_path / "a" / "router.log"
        deadline = time.monotonic() + 60
        while "listening on" not in (router_log.read_text() if router_log.exists() else ""):
            assert a.poll() is None, a.communicate()[0]
            assert time.monotonic() < deadline, "host a's router did not start in 60 s"
            time.sleep(0.1)  # polling a log file: there is no event to wait on
        b = subprocess.Popen(
            [
                "ip",
                "netns",
                "exec",
                ns_b,
                *run,
                "--host",
                "b",
                "--connect",
                f"tls/{addr}:7447",
                "--log-dir",
                str(tmp_path / "b"),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        code_a, out_a = _finish(a, 200)
        code_b, out_b = _finish(b, 60)
    finally:
        for p in (a, b):
            if p is not None and p.poll() is None:
                stop_run(p)
    assert code_a == 0, out_a
    assert "PASS collisions 0" in out_a
    assert re.search(r"ended at t=4\.0 s \(tick 40\), 1 robots", out_a), out_a  # driven from host b to the end
    assert code_b == 0, out_b
    assert sorted(p.stem for p in (tmp_path / "b").glob("*.log")) == ["collision", "driver", "sensors-1"]
    assert "access denied" not in (tmp_path / "a" / "router.log").read_text()
