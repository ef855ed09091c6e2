"""Foxglove live: a WebSocket client speaking the Foxglove protocol to a live run."""

from __future__ import annotations

import base64
import contextlib
import json
import struct
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgspec
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Origin, Subprotocol

from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.bus.net import free_port, port_in_use
from iw_zenoh.messages import LabMsg, WorldInfo, WorldState, decode, encode
from iw_zenoh.nodes.foxglove_gate import SDK
from iw_zenoh.nodes.foxglove_live import start_foxglove_live
from iw_zenoh.nodes.world_seal import SEAL_ENV, seal
from iw_zenoh.process.runtime import NodeIO
from iw_zenoh.record.channels import key_channel
from iw_zenoh.record.foxglove import SCENE_TOPIC, TF_TOPIC
from iw_zenoh.viewer.sources import LocalBus
from tests.integration.harness import Net
from tests.support.consumer import proto_message

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(180)]

LAB = """<Lab Name="test" Width="20" Height="10">
  <Wall Height="2"><Corner X="9" Y="0"/><Corner X="10" Y="0"/><Corner X="10" Y="3"/><Corner X="9" Y="3"/></Wall>
</Lab>"""
GRID = """<Grid><Position X="2" Y="5" Dir="0"/><Position X="5" Y="8" Dir="0"/><Position X="14" Y="5" Dir="0"/></Grid>"""
# Foxglove and Lichtblick offer both names; foxglove-sdk's server takes the newer one
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
MESSAGE_DATA = 0x01  # the server's binary opcode for a message on a subscription
TICKS = 12  # consecutive ticks the client must see drawn


def _live_run(net: Net) -> int:
    (net.tmp / "lab.xml").write_text(LAB)
    (net.tmp / "grid.xml").write_text(GRID)
    net.spawn("world", str(net.tmp / "lab.xml"), "--grid", str(net.tmp / "grid.xml"))
    net.spawn("collision")
    net.spawn("sensors")
    net.spawn("agent", "wanderer", "--count", "2", "--seed", "5", "--name", "herd")
    port = free_port()
    fox = net.spawn(  # iwz view serves Foxglove live too
        "view", "--port", "0", "--foxglove-port", str(port), "--foxglove-allow-origin", "https://lichtblick.example"
    )
    deadline = time.monotonic() + 60
    while not port_in_use(port):
        assert fox.popen.poll() is None, f"iwz view died:\n{fox.output()}"
        assert time.monotonic() < deadline, f"iwz view did not serve Foxglove in 60 s:\n{fox.output()}"
        time.sleep(0.02)  # polling a port: there is no event to wait on
    return port


def _listens_on_loopback_only(port: int) -> bool:
    """Whether every listening socket on ``port`` is bound to 127.0.0.1 (from /proc/net/tcp*)."""
    found = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            addr, hexport = local.split(":")
            if state == "0A" and int(hexport, 16) == port:  # 0A: LISTEN
                found.append(addr)
    return bool(found) and all(a == "0100007F" for a in found)


def _advertised(ws: ClientConnection, topics: set[str], timeout_s: float = 60.0) -> dict[str, dict[str, Any]]:
    """Every channel advertised until ``topics`` all are, by topic."""
    chans: dict[str, dict[str, Any]] = {}
    deadline = time.monotonic() + timeout_s
    while not topics <= chans.keys():
        left = deadline - time.monotonic()
        assert left > 0, f"not advertised within {timeout_s} s: {topics - chans.keys()} (got {sorted(chans)})"
        m = ws.recv(timeout=left)
        if isinstance(m, str) and json.loads(m)["op"] == "advertise":
            chans.update({c["topic"]: c for c in json.loads(m)["channels"]})
    return chans


def _message(ws: ClientConnection, timeout_s: float = 30.0) -> tuple[int, bytes]:
    """The next message on a subscription: (subscription id, payload)."""
    deadline = time.monotonic() + timeout_s
    while True:
        m = ws.recv(timeout=max(deadline - time.monotonic(), 0.001))
        if isinstance(m, bytes) and m[0] == MESSAGE_DATA:
            sub, _ts = struct.unpack_from("<IQ", m, 1)
            return sub, m[13:]


def _scene(channel: dict[str, Any], payload: bytes) -> Any:  # noqa: ANN401 (a generated protobuf class)
    """A scene update decoded with the descriptors its channel advertised (base64), as Foxglove does."""
    assert (channel["encoding"], channel["schemaEncoding"]) == ("protobuf", "protobuf")
    return proto_message(base64.b64decode(channel["schema"]), channel["schemaName"], payload)


def test_a_foxglove_client_is_offered_the_scene_and_state_and_sees_every_tick_drawn(net: Net) -> None:
    port = _live_run(net)
    with pytest.raises(InvalidStatus) as foreign:  # any site's page the user visits may not read it
        connect(
            f"ws://127.0.0.1:{port}",
            subprotocols=[Subprotocol(SDK)],
            origin=Origin("https://evil.example"),
            open_timeout=30,
        )
    assert foreign.value.response.status_code == 403
    assert "--foxglove-allow-origin" in foreign.value.response.body.decode()
    with connect(
        f"ws://127.0.0.1:{port}",
        subprotocols=[Subprotocol(SDK)],
        origin=Origin("https://lichtblick.example"),
        open_timeout=30,
    ):
        pass  # the origin added with --foxglove-allow-origin may
    assert _listens_on_loopback_only(port)
    state_key = keys.state(net.sim)
    with connect(f"ws://127.0.0.1:{port}", subprotocols=SUBPROTOCOLS, open_timeout=30) as ws:  # type: ignore[arg-type]
        assert ws.subprotocol == "foxglove.sdk.v1"
        chans = _advertised(ws, {SCENE_TOPIC, TF_TOPIC, state_key, keys.info(net.sim)})
        # the same channels as a recording: schema names, JSON Schemas, encodings
        state = chans[state_key]
        spec = key_channel(state_key)
        assert (state["encoding"], state["schemaEncoding"], state["schemaName"]) == (
            "json",
            "jsonschema",
            "iw.WorldState/1",
        )
        assert json.loads(state["schema"]) == json.loads(spec.schema)
        assert state["metadata"] == spec.metadata
        for topic, name in ((SCENE_TOPIC, "foxglove.SceneUpdate"), (TF_TOPIC, "foxglove.FrameTransform")):
            assert (chans[topic]["schemaName"], chans[topic]["encoding"]) == (name, "protobuf")  # Foxglove's own
        subs = {1: SCENE_TOPIC, 2: state_key}
        ws.send(
            json.dumps(
                {"op": "subscribe", "subscriptions": [{"id": i, "channelId": chans[t]["id"]} for i, t in subs.items()]}
            )
        )
        states: list[WorldState] = []
        drawn: set[int] = set()  # sim times of scene updates that place the robots
        walls = False
        while len(states) < TICKS or not {s.sim_time_ns for s in states} <= drawn:
            sub, payload = _message(ws)
            if subs[sub] == state_key:
                st = decode(payload, WorldState)
                if len(st.ids) == 2 or states:  # from when both chairs are in the world
                    states.append(st)
                continue
            for e in _scene(chans[SCENE_TOPIC], payload).entities:
                walls |= e.id == "walls"
                if e.id.startswith("robot/"):
                    drawn.add(e.timestamp.seconds * 1_000_000_000 + e.timestamp.nanos)
            assert len(states) < TICKS + 50, "the scene updates do not follow the ticks"
    ticks = [s.tick for s in states]
    assert ticks == list(range(ticks[0], ticks[0] + len(ticks)))  # every tick, in order, advancing
    assert all(len(s.ids) == 2 for s in states)
    assert walls  # sent again to a client that subscribes after the world described itself
    # a client that comes later still gets the walls (drawn once per world revision) when it subscribes
    with connect(f"ws://127.0.0.1:{port}", subprotocols=SUBPROTOCOLS, open_timeout=30) as late:  # type: ignore[arg-type]
        scene = _advertised(late, {SCENE_TOPIC})[SCENE_TOPIC]
        late.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": scene["id"]}]}))
        ids: set[str] = set()
        for _ in range(50):
            ids |= {e.id for e in _scene(scene, _message(late)[1]).entities}
            if "walls" in ids:
                break
        assert "walls" in ids, ids


def _subscribe(ws: ClientConnection, sub: int, channel: dict[str, Any]) -> None:
    ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": sub, "channelId": channel["id"]}]}))


def _one_client(port: int, sim: str, subprotocol: str) -> None:
    """A client offering only ``subprotocol`` gets the channels and their messages, and the world's
    description once, however many channels it subscribes to one after the other (as Foxglove's
    panels do)."""
    info_key, state_key = keys.info(sim), keys.state(sim)
    with connect(f"ws://127.0.0.1:{port}", subprotocols=[subprotocol], open_timeout=30) as ws:  # type: ignore[list-item]
        assert ws.subprotocol == subprotocol
        chans = _advertised(ws, {SCENE_TOPIC, TF_TOPIC, state_key, info_key})
        order = {1: info_key, 2: state_key, 3: SCENE_TOPIC, 4: TF_TOPIC}
        got: dict[str, int] = dict.fromkeys(order.values(), 0)
        revisions: list[int] = []  # of each description received

        def take() -> None:
            s, payload = _message(ws)
            got[order[s]] += 1
            if order[s] == info_key:
                assert json.loads(payload)["lab"]["walls"], "the world's description, walls and all"
                revisions.append(json.loads(payload)["revision"])

        for sub, topic in order.items():  # one subscription at a time, each once it is served
            _subscribe(ws, sub, chans[topic])
            while not got[topic]:
                take()
        states_then = got[state_key]
        while got[state_key] < states_then + 20:  # two more seconds of ticks
            take()
        # once per revision for this client: not again at each subscription, nor at each tick
        assert revisions == sorted(set(revisions)), (revisions, got)


def test_iwz_foxglove_serves_both_subprotocols_and_tells_a_refused_client_which(net: Net) -> None:
    (net.tmp / "lab.xml").write_text(LAB)
    (net.tmp / "grid.xml").write_text(GRID)
    net.spawn("world", str(net.tmp / "lab.xml"), "--grid", str(net.tmp / "grid.xml"))
    net.spawn("collision")
    net.spawn("sensors")
    net.spawn("agent", "wanderer", "--count", "2", "--seed", "5", "--name", "herd")
    port = free_port()
    fox = net.spawn("foxglove", "--port", str(port), "--allow-origin", "https://lichtblick.example")
    deadline = time.monotonic() + 60
    while not port_in_use(port):
        assert fox.popen.poll() is None, f"iwz foxglove died:\n{fox.output()}"
        assert time.monotonic() < deadline, f"iwz foxglove did not listen in 60 s:\n{fox.output()}"
        time.sleep(0.02)  # polling a port: there is no event to wait on
    assert _listens_on_loopback_only(port)
    _one_client(port, net.sim, "foxglove.websocket.v1")  # Lichtblick, @foxglove/ws-protocol
    _one_client(port, net.sim, "foxglove.sdk.v1")  # Foxglove
    with pytest.raises(InvalidStatus) as refused:
        connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.websocket.v2"], open_timeout=30)  # type: ignore[list-item]
    assert refused.value.response.status_code == 400
    why = refused.value.response.body.decode()
    assert "foxglove.sdk.v1" in why
    assert "foxglove.websocket.v1" in why
    assert "offered foxglove.websocket.v2" in why
    assert fox.popen.poll() is None  # the refusal cost the server nothing
    _one_client(port, net.sim, "foxglove.sdk.v1")
    # another site's page may not read the run; the origin added with --allow-origin may
    with pytest.raises(InvalidStatus) as foreign:
        connect(
            f"ws://127.0.0.1:{port}",
            subprotocols=[Subprotocol(SDK)],
            origin=Origin("https://evil.example"),
            open_timeout=30,
        )
    assert foreign.value.response.status_code == 403
    assert "--allow-origin" in foreign.value.response.body.decode()
    with connect(
        f"ws://127.0.0.1:{port}",
        subprotocols=[Subprotocol(SDK)],
        origin=Origin("https://lichtblick.example"),
        open_timeout=30,
    ) as ws:
        assert json.loads(ws.recv(timeout=30))["op"] == "serverInfo"


def _described(live_port: int, sim: str, want: bytes, put: Callable[[], None]) -> list[bytes]:
    """The descriptions a client subscribed to ``world/info`` gets until ``want`` (or 15 s), the
    client connected before ``put`` feeds the server (its channels are then advertised to it)."""
    got: list[bytes] = []
    with connect(f"ws://127.0.0.1:{live_port}", subprotocols=[Subprotocol(SDK)], open_timeout=30) as ws:
        assert json.loads(ws.recv(timeout=30))["op"] == "serverInfo"
        put()
        # the walls' scene is advertised after the description's channel: that one is known by then
        _subscribe(ws, 1, _advertised(ws, {keys.info(sim), SCENE_TOPIC})[keys.info(sim)])
        deadline = time.monotonic() + 15
        while want not in got and time.monotonic() < deadline:
            with contextlib.suppress(TimeoutError):
                got.append(_message(ws, timeout_s=max(deadline - time.monotonic(), 0.01))[1])
    return got


@pytest.mark.parametrize("key", [None, bytes(range(32))], ids=["no-key", "sealed"])
def test_a_forged_description_of_the_current_revision_does_not_shut_out_the_worlds(
    key: bytes | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    if key is None:
        monkeypatch.delenv(SEAL_ENV, raising=False)
    else:  # a process iwz run gave the seal key: only the world's sealed descriptions are served
        monkeypatch.setenv(SEAL_ENV, key.hex())
    bus = LocalBus(Inbox())
    live = start_foxglove_live(NodeIO(bus, "s", "viewer", "foxglove"), "127.0.0.1", 0)
    try:
        inbox = bus._subs[keys.everything("s")]
        info = WorldInfo(revision=3, lab=LabMsg(name="lab", width=20.0, height=10.0), period_ns=1, sim="s")
        forged = encode(msgspec.structs.replace(info, lab=LabMsg(name="forged", width=1.0, height=1.0)))
        real = encode(seal(info, key))

        def put() -> None:
            inbox.put((keys.info("s"), forged, time.time_ns()))  # first, with the revision the world has
            inbox.put((keys.info("s"), real, time.time_ns()))

        got = _described(live.port, "s", real, put)
        assert real in got, f"the world's description was not served: {got}"
        if key is not None:
            assert forged not in got
        inbox.put((keys.info("s"), real, time.time_ns()))  # the same again (published, then answered)
        inbox.put((keys.info("s"), b'{"revision": 4', time.time_ns()))  # junk: one bad message
        assert live._thread.is_alive()
    finally:
        live.close()
