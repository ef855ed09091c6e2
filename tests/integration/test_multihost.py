"""Several hosts: the world in one network namespace, sensors, collision and the agent in
another, joined by a veth pair with addresses of their own. Needs root and iproute2 (CI has
both); the namespaces are removed afterwards whatever happens."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.integration import netns
from tests.integration.harness import ROOT, Net

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(180)]

LAB = '<Lab Name="open" Width="20" Height="10"/>'


@pytest.fixture
def two_hosts() -> Iterator[tuple[str, str, str]]:
    """Two namespaces joined by a veth pair: yields (ns_a, ns_b, address of a); always removed."""
    with netns.two_hosts("z", "10.231.200") as hosts:
        yield hosts


def test_a_run_split_across_two_hosts_completes_as_on_one(two_hosts: tuple[str, str, str], tmp_path: Path) -> None:
    ns_a, ns_b, addr = two_hosts
    (tmp_path / "lab.xml").write_text(LAB)
    net = Net(tmp_path, sim="mh", port=7447, endpoint_host=addr)
    in_a = ["ip", "netns", "exec", ns_a]
    in_b = ["ip", "netns", "exec", ns_b]
    try:
        net.start_router(listen=f"tcp/{addr}:7447", prefix=in_a)
        observer = subprocess.Popen(
            [*in_a, sys.executable, "-m", "tests.integration.observe", net.endpoint, "mh", "20"],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        try:
            assert observer.stdout is not None
            assert observer.stdout.readline().strip() == "ready"  # blocks until the observer subscribed
            world = net.spawn(
                "world", str(tmp_path / "lab.xml"), "--lockstep", "--expect", "1", "--duration", "2", prefix=in_a
            )
            net.spawn("collision", prefix=in_b)
            net.spawn("sensors", prefix=in_b)
            net.spawn("agent", "waypoint", "--waypoints", "15,5", "--start", "3,5,0", "--name", "remote", prefix=in_b)
            assert world.popen.wait(120) == 0, world.output()
            out, _ = observer.communicate(timeout=60)
        finally:
            if observer.poll() is None:
                observer.kill()
                observer.wait(5)
        summary = json.loads(out.strip().splitlines()[-1])
        assert summary["ticks"] == list(range(1, 21))
        (x0, _), (x1, _) = summary["first"]["1"], summary["final"]["1"]
        assert x1 > x0 + 0.1, "the chair driven from the other host moved"
    finally:
        net.close()
