"""Foxglove live: a WebSocket client speaking the Foxglove protocol to a live run."""

from __future__ import annotations

import json
import struct
import time
from pathlib import Path
from typing import Any

import pytest
from websockets.sync.client import ClientConnection, connect

from iw_zenoh import keys
from iw_zenoh.messages import WorldState, decode, json_schema
from iw_zenoh.net import free_port, port_in_use
from iw_zenoh.record.channels import key_channel
from iw_zenoh.record.foxglove import SCENE_TOPIC, TF_TOPIC, FgFrameTransform, FgSceneUpdate
from tests.integration.harness import Net

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
    fox = net.spawn("view", "--port", "0", "--foxglove-port", str(port))  # iwz view serves Foxglove live too
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


def test_a_foxglove_client_is_offered_the_scene_and_state_and_sees_every_tick_drawn(net: Net) -> None:
    port = _live_run(net)
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
        for topic, kind in ((SCENE_TOPIC, FgSceneUpdate), (TF_TOPIC, FgFrameTransform)):
            assert chans[topic]["schemaName"] == kind.schema
            assert json.loads(chans[topic]["schema"]) == json_schema(kind)
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
            for e in json.loads(payload)["entities"]:
                walls |= e["id"] == "walls"
                if e["id"].startswith("robot/"):
                    drawn.add(e["timestamp"]["sec"] * 1_000_000_000 + e["timestamp"]["nsec"])
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
            ids |= {e["id"] for e in json.loads(_message(late)[1])["entities"]}
            if "walls" in ids:
                break
        assert "walls" in ids, ids
