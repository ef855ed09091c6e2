"""What a flood costs the legacy bridge, over real UDP with real processes: a good robot misses no
cycle, the log and the bus get a bounded amount, sockets are not leaked, a taken port is refused.

The figures are printed (run with ``-s`` to read them). A long soak is ``benchmarks/legacy.py``'s.
"""

from __future__ import annotations

import contextlib
import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from lxml import etree

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import NetConfig
from iw_zenoh.messages import Event, WorldState, decode
from tests.integration.harness import MAPS, Net, iwz_run_argv, stop_run, subscribe
from tests.integration.legacy import LegacyClient, udp_port

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

FLOOD = 120_000  # datagrams
SOURCES = 1024  # sockets, each its own source port
LOG_BOUND = 100_000  # bytes the bridge's log may grow by during the flood
TIME_RE = re.compile(rb'<Measures Time="(\d+)"')

# the flooder: SOURCES sockets in turn, malformed datagrams of every kind, a bounded loop,
# loopback only; paced to about 50,000 a second so that the flood lasts a few seconds. It runs at
# the lowest priority: what is measured is what the flood costs the bridge, not how a local
# attacker's own CPU starves the run's processes on a small machine (a flood from the network
# costs this machine no process time)
FLOODER = r"""
import os, socket, sys, time
os.nice(19)
port, n, k = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
socks = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(k)]
junk = [b"\xff\xfe", b"<Robot", b"<Hack/>", b'<Robot Id="\xd9\xa3"/>', b"<View>" + b"x" * 900,
        b"<Actions/>", b'<!DOCTYPE r [<!ENTITY a "b">]><Robot Name="&a;"/>', b"\x00" * 64]
sent = 0
start = time.monotonic()
for i in range(n):
    try:
        socks[i % k].sendto(junk[i % len(junk)], ("127.0.0.1", port))
        sent += 1
    except OSError:
        pass
    if i % 500 == 499:
        ahead = (i + 1) / 50_000 - (time.monotonic() - start)
        if ahead > 0:
            time.sleep(ahead)  # pacing the sender, not waiting on anything
print(sent, time.monotonic() - start, flush=True)
"""


def _pid_of(pattern: str) -> int:
    """The pid of the process whose command line holds ``pattern``."""
    for pid in (p for p in os.listdir("/proc") if p.isdigit()):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\x00", b" ").decode(errors="replace")
        except OSError:
            continue
        if pattern in cmd and "pytest" not in cmd:
            return int(pid)
    raise AssertionError(f"no process runs {pattern!r}")


def _fds(pid: int) -> int:
    return len(os.listdir(f"/proc/{pid}/fd"))


def _drive(robot: LegacyClient, times: list[int], cycles: int, during: subprocess.Popen[str] | None = None) -> None:
    """Drives the robot as an agent does (an Actions for every Measures) while ``during`` runs,
    then ``cycles`` cycles more; the Time of every Measures into ``times``."""
    after = 0
    while after < cycles:
        data = robot.recv()  # croblink's 2 s timeout: a robot left without Measures fails here
        m = TIME_RE.match(data)
        if m:
            times.append(int(m.group(1)))
        robot.send(b'<Actions LeftMotor="0.05" RightMotor="0.05"/>')
        if during is None or during.poll() is not None:
            after += 1


def test_a_flood_from_many_ports_costs_the_run_a_bounded_amount(tmp_path: Path) -> None:
    port = udp_port()
    text = (MAPS / "scenarios" / "ciberrato-c1.toml").read_text().replace("port = 6000", f"port = {port}")
    sc = tmp_path / "c1.toml"
    sc.write_text(text.replace('"../ciberrato/', f'"{MAPS}/ciberrato/'))
    argv = iwz_run_argv(sc, tmp_path, "flood")
    endpoint = f"tcp/127.0.0.1:{argv[argv.index('--port') + 1]}"
    run = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    robot = LegacyClient(port)
    bus: ZenohBus | None = None
    try:
        reply = robot.register(b'<Robot Id="1" Name="good"/>', tries=60)
        assert etree.fromstring(reply[:-1]).get("Status") == "Ok"
        bus = ZenohBus(NetConfig(connect=(endpoint,)))
        events = subscribe(bus, keys.event("flood", "legacy-refused"))
        states = subscribe(bus, keys.state("flood"))
        launched = f'bridge ciberrato --options {{"port":{port},'  # iwz run hands it its options whole
        bridge_pid = _pid_of(launched)
        log = tmp_path / "bridge.log"
        times: list[int] = []
        _drive(robot, times, 20)  # the world runs: Time goes up by one a cycle
        log_before = log.stat().st_size
        flooder = subprocess.Popen(
            [sys.executable, "-c", FLOODER, str(port), str(FLOOD), str(SOURCES)], stdout=subprocess.PIPE, text=True
        )
        times.clear()
        _drive(robot, times, 40, during=flooder)
        out, _ = flooder.communicate(timeout=60)
        sent, flood_s = int(out.split()[0]), float(out.split()[1])
        log_growth = log.stat().st_size - log_before
        refusals = [decode(d, Event) for _, d, _ in events.drain()]
        during = [decode(d, WorldState) for _, d, _ in states.drain()]
        held = sum(st.held for st in during if min(times) <= st.tick <= max(times))
        assert run.poll() is None, "the run ended under the flood"
        assert _pid_of(launched) == bridge_pid  # the same bridge: never restarted
    finally:
        robot.close()
        if bus is not None:
            bus.close()
        output, _ = stop_run(run)
    missed = (max(times) - min(times) + 1) - len(set(times))
    counted = sum(int(e.data.get("count", 1)) for e in refusals)
    print(
        f"\nflood: {sent} datagrams from {SOURCES} source ports in {flood_s:.1f} s; good robot: {len(times)} "
        f"Measures, Time {min(times)}..{max(times)}, {missed} cycles missed; bridge log +{log_growth} bytes; "
        f"{len(refusals)} refusal events on the bus, counting {counted} datagrams the bridge read and refused; "
        f"the world held its robots {held} times"
    )
    assert sent >= 100_000
    assert missed == 0, times
    assert log_growth < LOG_BOUND
    assert len(refusals) <= flood_s + 10  # one address: one event a second (and the first at once)
    assert "restarting" not in output, output


def test_a_bridge_whose_port_is_taken_refuses_to_start_and_says_who_has_it() -> None:
    holder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    holder.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the bridge's own port was bound
    holder.bind(("127.0.0.1", 0))
    port = holder.getsockname()[1]
    try:
        argv = [sys.executable, "-m", "iw_zenoh.cli", "bridge", "ciberrato", "--port", str(port), "--sim", "taken"]
        done = subprocess.run(argv, capture_output=True, text=True, timeout=60)
    finally:
        holder.close()
    out = done.stdout + done.stderr
    assert done.returncode != 0, out
    assert f"UDP 127.0.0.1:{port}" in out
    assert f"taken by pid {os.getpid()} " in out  # this test's process, and its command line
    own_argv0 = Path("/proc/self/cmdline").read_bytes().split(b"\0")[0].decode()
    assert own_argv0 in out  # its command line (pytest's, or an xdist worker's: not "pytest" then)


def test_thousands_of_viewer_registrations_leave_no_sockets_behind(net: Net, clients: list[LegacyClient]) -> None:
    port = udp_port()
    lab, grid = MAPS / "ciberrato" / "C1-lab.xml", MAPS / "ciberrato" / "C1-grid.xml"
    net.spawn("world", str(lab), "--grid", str(grid), "--profile", "ciberrato", "--period-ms", "50")
    net.spawn("bridge", "ciberrato", "--port", str(port))
    robot = LegacyClient(port)  # a robot: every viewer is sent its state every cycle
    clients.append(robot)
    assert b'Status="Ok"' in robot.register(b'<Robot Id="1" Name="seen"/>', tries=60)
    pid = _pid_of(f"bridge ciberrato --port {port}")
    before = _fds(pid)
    answers: dict[bytes, int] = {}
    for i in range(2000):  # each from a socket of its own, closed once answered (8 loopback addresses)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.bind((f"127.0.0.{2 + i % 8}", 0))
            s.settimeout(2.0)
            s.sendto(b"<View/>\n\x00", ("127.0.0.1", port))
            with contextlib.suppress(TimeoutError):
                status = s.recv(2048)[:22]
                answers[status] = answers.get(status, 0) + 1
    peak = _fds(pid)
    deadline = time.monotonic() + 30
    while _fds(pid) > before + 2 and time.monotonic() < deadline:
        time.sleep(0.05)  # polling a count in /proc: there is no event to wait on
    after = _fds(pid)
    print(f"\n2000 <View/>: answers {answers}; bridge fds {before} before, {peak} at most, {after} after")
    assert peak - before <= 32 + 2  # MAX_VIEWERS at most, whatever the number of registrations
    assert after <= before + 2  # viewers nobody listens for any more are let go, their sockets closed
    viewer = LegacyClient(port)  # and a real viewer is served
    clients.append(viewer)
    assert b'Status="Ok"' in viewer.register(b"<View/>\n\x00")
