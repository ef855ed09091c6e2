"""A secured simulation on loopback (issue 20): real certificates, a router enforcing the policy
over mutual TLS, real world, collision, sensors and agent processes, and a rogue session holding
a valid agent certificate that tries everything the issue lists. Each attempt is checked where it
would show: the victim's pose, the world's clock, a subscriber of the forged key, the router's log.
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.bus import Inbox, ZenohBus
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use
from iw_zenoh.errors import IwError
from iw_zenoh.messages import (
    ActionBatch,
    Actions,
    Control,
    PoseReport,
    RegisterReply,
    RegisterRequest,
    RobotSpecMsg,
    WorldState,
    decode,
    encode,
)
from iw_zenoh.secure.certs import init_ca, issue
from iw_zenoh.secure.cli import add_identity
from tests.integration.harness import Net, Proc, state_of, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

LAB = '<Lab Name="open" Width="20" Height="10"/>'
GRID = '<Grid><Position X="4" Y="3" Dir="0"/><Position X="4" Y="7" Dir="0"/></Grid>'
QUICK = ("connect/timeout_ms:{client: 3000}",)  # a refused connection is known in seconds
FORGED = b'{"forged": true}'
ROLES = {"world": "world", "collision": "collision", "sensors": "sensors", "radio": "radio", "observer": "recorder"}


@dataclass
class Secured:
    """A running secured simulation and the test's own sessions."""

    net: Net
    ids: Path
    endpoint: str
    router: Proc
    world: Proc
    observer: ZenohBus
    rogue: ZenohBus
    bystander: list[ZenohBus] = field(default_factory=list)  # the bystander's session, once it registered

    def session(self, identity: str | None, endpoint: str | None = None) -> ZenohBus:
        """A client session of the test as ``identity`` (None: without any certificate)."""
        return _client(self.net, self.ids, endpoint or self.endpoint, identity)


def _client(net: Net, ids: Path, endpoint: str, identity: str | None) -> ZenohBus:
    ident = str(ids / identity) if identity else None
    bus = ZenohBus(NetConfig(connect=(endpoint,), identity=ident, overrides=QUICK))
    net.buses.append(bus)
    return bus


def _identities(ids: Path) -> None:
    init_ca(ids)
    issue(ids, "router", server=True)
    for name, role in ROLES.items():
        issue(ids, name)
        add_identity(ids / "policy.toml", name, [role])
    for name, robots in (("victim", [1]), ("rogue", [2]), ("bystander", [3, 5])):
        issue(ids, name)
        add_identity(ids / "policy.toml", name, ["agent"], robots=robots)
    for name, role, chair in (
        ("bridger", "bridge", []),
        ("serialer", "serial", [4]),
    ):  # a bridge's and a serial bridge's
        issue(ids, name)
        add_identity(ids / "policy.toml", name, [role], robots=chair)
    issue(ids, "stranger")  # of the authority, but no identity of the policy
    text = (ids / "policy.toml").read_text().replace('sim = "default"', 'sim = "sec"')
    (ids / "policy.toml").write_text(text)


def _spawn(net: Net, ids: Path, endpoint: str, name: str, *args: str) -> Proc:
    argv = [sys.executable, "-m", "iw_zenoh.cli", *args, "--sim", net.sim, "--name", name]
    return net.launch(name, [*argv, "--identity", str(ids / name), "-e", endpoint])


@pytest.fixture(scope="module")
def secured(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Secured]:
    """Router (policy), world (policy), collision, sensors, and the victim: a chair standing still."""
    tmp = tmp_path_factory.mktemp("secure")
    ids = tmp / "ids"
    _identities(ids)
    (tmp / "lab.xml").write_text(LAB)
    (tmp / "grid.xml").write_text(GRID)
    net = Net(tmp, sim="sec")
    try:
        router = net.start_secured_router(ids)
        endpoint = net.endpoint
        lab = [str(tmp / "lab.xml"), "--grid", str(tmp / "grid.xml"), "--policy", str(ids / "policy.toml")]
        world = _spawn(net, ids, endpoint, "world", "world", *lab)
        yield _start(net, ids, endpoint, router, world)
    finally:
        net.close()


def _start(net: Net, ids: Path, endpoint: str, router: Proc, world: Proc) -> Secured:
    _spawn(net, ids, endpoint, "collision", "collision")
    _spawn(net, ids, endpoint, "sensors", "sensors")
    _spawn(net, ids, endpoint, "victim", "agent", "probe")
    observer = _client(net, ids, endpoint, "observer")
    s = Secured(net, ids, endpoint, router, world, observer, _client(net, ids, endpoint, "rogue"))
    states = Inbox(maxlen=1)
    s.observer.subscribe(keys.state("sec"), states)
    wait_msg(states, WorldState, lambda m: 1 in m.ids, timeout_s=90)  # the victim is registered and ticking
    return s


def _victim_pose(states: Inbox) -> tuple[float, float, float]:
    x, y, h, _ = state_of(wait_msg(states, WorldState, lambda m: 1 in m.ids), 1)
    return x, y, h


def _flood(seconds: float, *sends: tuple[ZenohBus, str, bytes]) -> None:
    """Publishes each payload every 20 ms for ``seconds`` (what a driving agent would send)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for bus, key, data in sends:
            bus.publish(key, data)
        time.sleep(0.02)  # a sender's pace, not synchronisation


def test_a_rogue_agent_cannot_drive_another_agents_chair(secured: Secured) -> None:
    states = Inbox(maxlen=1)
    secured.observer.subscribe(keys.state("sec"), states)
    before = _victim_pose(states)
    spin = Actions(robot_id=1, left=0.15, right=-0.15)
    _flood(
        3.0,
        (secured.rogue, keys.actions("sec", 1), encode(spin)),
        (secured.rogue, keys.agent_actions("sec", "victim"), encode(ActionBatch(agent="victim", actions=[spin]))),
        (secured.rogue, keys.agent_actions("sec", "rogue"), encode(ActionBatch(agent="rogue", actions=[spin]))),
    )
    after = _victim_pose(states)
    assert after == pytest.approx(before, abs=1e-9), "the victim's chair moved under the rogue's actions"


def _register_for_bystander(secured: Secured, spec: RobotSpecMsg) -> ZenohBus:
    """Registers a robot for agent bystander from its session, which declares the agent's
    liveliness token first (as an agent host does: the world keeps the robot); the session."""
    if not secured.bystander:
        bystander = secured.session("bystander")
        bystander.token(keys.alive("sec", "agent", "bystander"))
        secured.bystander.append(bystander)
    req = encode(RegisterRequest(spec=spec, agent="bystander"))
    answer = secured.bystander[0].query(keys.register("sec", "bystander"), req, timeout_s=10)
    reply = decode(answer[0], RegisterReply)
    assert reply.ok, reply.reason
    return secured.bystander[0]


def _bystander(secured: Secured, states: Inbox) -> tuple[float, float, float]:
    """Robot 3, registered by the test for agent bystander (once: the bystander's session declares
    the agent's liveliness token, as an agent host does, so the world keeps the robot) and never
    commanded by it, so that any command which reaches the world shows; its pose. A robot 3 gone
    since fails the test rather than being registered again at its start pose (where "it did not
    move" would hold whether the grant did or not)."""
    if not secured.bystander:
        _register_for_bystander(secured, RobotSpecMsg(name="bystander-chair", id=3, x_m=10.0, y_m=5.0, dir_deg=0.0))
    now = wait_msg(states, WorldState).tick  # a state of 10 ticks later: every command sent before applied
    later = wait_msg(states, WorldState, lambda m: m.tick > now + 10)
    assert 3 in later.ids, "the bystander's robot 3 was removed from the world"
    x, y, h, _ = state_of(later, 3)
    return x, y, h


@pytest.mark.parametrize("identity", ["bridger", "serialer"])
def test_a_bridge_identity_cannot_drive_an_agents_chair(secured: Secured, identity: str) -> None:
    """A bridge's certificate (a stolen one, a buggy bridge) publishing another agent's robot's
    actions on its key, and in batches of its own and of that agent's, never moves the robot: a
    bridge is granted actions only in its own batch, which the world takes only for robots it
    registered; the serial bridge is granted none."""
    bridge = secured.session(identity)
    states = Inbox(maxlen=1)
    secured.observer.subscribe(keys.state("sec"), states)
    before = _bystander(secured, states)
    spin = Actions(robot_id=3, left=0.15, right=-0.15)
    _flood(
        3.0,
        (bridge, keys.actions("sec", 3), encode(spin)),
        (bridge, keys.agent_actions("sec", identity), encode(ActionBatch(agent=identity, actions=[spin]))),
        (bridge, keys.agent_actions("sec", "bystander"), encode(ActionBatch(agent="bystander", actions=[spin]))),
    )
    after = _bystander(secured, states)
    assert after == pytest.approx(before, abs=1e-9), f"agent bystander's chair moved under {identity}'s actions"


def test_a_serial_bridge_certificate_moves_no_real_robot_but_its_chair(secured: Secured) -> None:
    """A serial bridge's certificate (a stolen one, a buggy bridge) reporting the pose of a Real
    robot of another agent never moves it: it is granted pose reports for its chair only; the
    robot's own agent's reports do move it (so the reports do reach the world)."""
    states = Inbox(maxlen=1)
    secured.observer.subscribe(keys.state("sec"), states)
    _bystander(secured, states)  # the bystander's session, its token declared
    owner = _register_for_bystander(
        secured, RobotSpecMsg(name="real", id=5, x_m=15.0, y_m=8.0, dir_deg=0.0, type="Real")
    )
    tick = wait_msg(states, WorldState, lambda m: 5 in m.ids).tick
    report = encode(PoseReport(tick=tick, robot_id=5, x=2.0, y=2.0, dir_deg=90.0))
    _flood(2.0, (secured.session("serialer"), keys.pose_report("sec", 5), report))
    now = wait_msg(states, WorldState).tick
    x, y, _, _ = state_of(wait_msg(states, WorldState, lambda m: m.tick > now + 10), 5)
    assert (x, y) == pytest.approx((15.0, 8.0), abs=1e-6), "the serial certificate moved another agent's Real robot"
    _flood(2.0, (owner, keys.pose_report("sec", 5), report))
    now = wait_msg(states, WorldState).tick
    x, y, _, _ = state_of(wait_msg(states, WorldState, lambda m: m.tick > now + 10), 5)
    assert (x, y) == pytest.approx((2.0, 2.0), abs=1e-6), (
        "its own agent's report did not move it: the test proves nothing"
    )


def test_the_rogue_drives_its_own_chair_so_its_messages_do_arrive(secured: Secured) -> None:
    spec = RobotSpecMsg(name="rogue-chair", id=2)
    answer = secured.rogue.query(
        keys.register("sec", "rogue"), encode(RegisterRequest(spec=spec, agent="rogue")), timeout_s=10
    )
    reply = decode(answer[0], RegisterReply)
    assert reply.ok, reply.reason
    states = Inbox(maxlen=1)
    secured.observer.subscribe(keys.state("sec"), states)
    h0 = state_of(wait_msg(states, WorldState, lambda m: 2 in m.ids), 2)[2]
    _flood(2.0, (secured.rogue, keys.actions("sec", 2), encode(Actions(robot_id=2, left=0.15, right=-0.15))))
    h1 = state_of(wait_msg(states, WorldState, lambda m: 2 in m.ids), 2)[2]
    assert abs(h1 - h0) > 0.1, "the rogue's own robot did not turn: the test would prove nothing"


@pytest.mark.parametrize("command", ["stop", "pause", "step"])
def test_a_rogue_agent_cannot_stop_pause_or_step_the_world(secured: Secured, command: str) -> None:
    states = Inbox(maxlen=1)
    secured.observer.subscribe(keys.state("sec"), states)
    _flood(1.0, (secured.rogue, keys.control("sec"), encode(Control(command=command))))  # type: ignore[arg-type]
    t0 = wait_msg(states, WorldState).tick
    t1 = wait_msg(states, WorldState, lambda m: m.tick >= t0 + 10, timeout_s=20).tick
    assert t1 >= t0 + 10
    assert secured.world.popen.poll() is None


def test_a_rogue_agent_cannot_register_under_another_name(secured: Secured) -> None:
    request = encode(RegisterRequest(spec=RobotSpecMsg(name="fake", id=0), agent="victim"))
    assert secured.rogue.query(keys.register("sec", "victim"), request, timeout_s=3) == []  # never reaches the world
    assert secured.rogue.query(keys.register("sec"), request, timeout_s=3) == []  # the shared key: bridges only
    [answer] = secured.rogue.query(keys.register("sec", "rogue"), request, timeout_s=10)
    reply = decode(answer, RegisterReply)
    assert not reply.ok
    assert "victim" in reply.reason
    assert "rogue" in reply.reason


@pytest.mark.parametrize(
    "key",
    [
        keys.verdict("sec"),
        keys.sensor_batch("sec", (1, 1)),
        keys.sensors("sec", 1),
        keys.state("sec"),
        keys.tick("sec"),
        keys.hear("sec", 1),
    ],
)
def test_a_forged_verdict_reading_or_state_never_reaches_a_subscriber(secured: Secured, key: str) -> None:
    box = Inbox()
    secured.observer.subscribe(key, box)
    _flood(1.0, (secured.rogue, key, FORGED))
    real = Inbox(maxlen=1)
    secured.observer.subscribe(keys.state("sec"), real)
    wait_msg(real, WorldState)  # the observer is being sent what the world publishes meanwhile
    assert not [d for d in box.drain() if d[1] == FORGED]


def test_the_router_logs_each_refused_publication_with_identity_and_key(secured: Secured) -> None:
    _flood(0.5, (secured.rogue, keys.control("sec"), encode(Control(command="stop"))))
    want = f"access denied: Put from 'rogue' on {keys.control('sec')}"
    deadline = time.monotonic() + 20
    seen = threading.Event()
    while not seen.is_set() and time.monotonic() < deadline:
        if want in secured.router.output():
            seen.set()
        else:
            time.sleep(0.1)  # polling a log file: there is no event to wait on
    assert seen.is_set(), secured.router.output()[-2000:]


def test_a_certificate_the_policy_does_not_name_may_do_nothing_and_is_logged(secured: Secured) -> None:
    stranger = secured.session("stranger")
    box = Inbox()
    stranger.subscribe(keys.state("sec"), box)
    states = Inbox(maxlen=1)
    secured.observer.subscribe(keys.state("sec"), states)
    _flood(1.0, (stranger, keys.control("sec"), encode(Control(command="pause"))))
    t0 = wait_msg(states, WorldState).tick
    wait_msg(states, WorldState, lambda m: m.tick >= t0 + 10, timeout_s=20)  # the world runs on
    assert len(box) == 0  # and the stranger is sent nothing of it
    deadline = time.monotonic() + 20
    while "(no identity of the policy)" not in secured.router.output():
        assert time.monotonic() < deadline, secured.router.output()[-2000:]
        time.sleep(0.1)  # polling a log file: there is no event to wait on


def test_a_process_without_a_certificate_cannot_connect(secured: Secured) -> None:
    with pytest.raises(IwError):
        secured.session(None)


def test_a_certificate_of_another_authority_is_refused(secured: Secured, tmp_path: Path) -> None:
    init_ca(tmp_path)
    issue(tmp_path, "victim")  # the right name, the wrong authority
    with pytest.raises(IwError):
        ZenohBus(NetConfig(connect=(secured.endpoint,), identity=str(tmp_path / "victim"), overrides=QUICK))


def test_plain_tcp_is_refused(secured: Secured) -> None:
    with pytest.raises(IwError):
        secured.session(None, endpoint=f"tcp/127.0.0.1:{secured.net.port}")


def test_a_process_without_a_certificate_cannot_even_start_a_role(secured: Secured) -> None:
    argv = [sys.executable, "-m", "iw_zenoh.cli", "collision", "--sim", "sec", "-e", secured.endpoint]
    done = subprocess.run([*argv, "--cfg", QUICK[0]], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "cannot join the bus" in done.stdout


def test_the_router_listens_where_its_config_file_says_and_reports_a_flag_replacing_it(tmp_path: Path) -> None:
    net = Net(tmp_path, sim="cf")
    try:
        port, other = free_port(), free_port()
        conf = tmp_path / "router.json5"
        conf.write_text(f'{{ listen: {{ endpoints: ["tcp/127.0.0.1:{port}"] }} }} // as zenohd reads it\n')
        cli = [sys.executable, "-m", "iw_zenoh.cli", "router", "--zenoh-config", str(conf)]
        first = net.launch("router-file", cli)
        second = net.launch("router-flag", [*cli, "--listen", f"tcp/127.0.0.1:{other}"])
        deadline = time.monotonic() + 30
        while not (port_in_use(port) and port_in_use(other)):
            assert first.popen.poll() is None, first.output()
            assert second.popen.poll() is None, second.output()
            assert time.monotonic() < deadline, f"{first.output()}\n{second.output()}"
            time.sleep(0.05)  # polling a port: there is no event to wait on
        while "listening on" not in second.output():
            assert time.monotonic() < deadline, second.output()
            time.sleep(0.05)  # polling a log file: there is no event to wait on
        assert f'listen/endpoints = ["tcp/127.0.0.1:{port}"] is overridden by --listen' in second.output()
    finally:
        net.close()
