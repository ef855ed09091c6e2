"""The gate of Foxglove live in front of a real foxglove-sdk server: both subprotocol names are
served, anything else is refused with the served names, hostile handshakes cost a bounded amount."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import foxglove
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from iw_zenoh.nodes.foxglove_gate import CLIENTS_MAX, HEAD_MAX, SDK, WEBSOCKET, FoxgloveGate, rewrite_head

pytestmark = [pytest.mark.timeout(120)]


@pytest.fixture
def gate() -> Iterator[FoxgloveGate]:
    server = foxglove.start_server(host="127.0.0.1", port=0, context=foxglove.Context())
    g = FoxgloveGate("127.0.0.1", 0, server.port)
    try:
        yield g
    finally:
        g.close()
        server.stop()


def _head(*protocols: str) -> bytes:
    lines = ["GET / HTTP/1.1", "Host: x", "Upgrade: websocket"] + [f"Sec-WebSocket-Protocol: {p}" for p in protocols]
    return ("\r\n".join(lines) + "\r\n\r\n").encode()


@pytest.mark.parametrize("offered", [[SDK], [WEBSOCKET], [WEBSOCKET, SDK], ["other", WEBSOCKET]])
def test_each_name_of_the_protocol_is_served_under_the_name_offered(gate: FoxgloveGate, offered: list[str]) -> None:
    with connect(f"ws://127.0.0.1:{gate.port}", subprotocols=offered, open_timeout=10) as ws:  # type: ignore[arg-type]
        assert ws.subprotocol == (SDK if SDK in offered else WEBSOCKET)
        assert '"op":"serverInfo"' in str(ws.recv(timeout=10)).replace(" ", "")


@pytest.mark.parametrize("offered", [[], ["foxglove.websocket.v2"]])
def test_a_client_offering_neither_is_told_which_are_served(gate: FoxgloveGate, offered: list[str]) -> None:
    with pytest.raises(InvalidStatus) as e:
        connect(f"ws://127.0.0.1:{gate.port}", subprotocols=offered or None, open_timeout=10)  # type: ignore[arg-type]
    assert e.value.response.status_code == 400
    why = e.value.response.body.decode()
    assert f"serves the subprotocols {SDK} and {WEBSOCKET}" in why
    assert f"offered {offered[0] if offered else 'none'}" in why
    with connect(f"ws://127.0.0.1:{gate.port}", subprotocols=[WEBSOCKET], open_timeout=10) as ws:  # type: ignore[list-item]
        assert ws.subprotocol == WEBSOCKET  # the refusal cost the others nothing


def test_a_huge_head_and_a_flood_of_clients_are_refused_and_the_gate_still_serves(gate: FoxgloveGate) -> None:
    with socket.create_connection(("127.0.0.1", gate.port), timeout=10) as s:
        s.sendall(b"GET / HTTP/1.1\r\nX: " + b"a" * (HEAD_MAX + 10))
        assert s.recv(100).startswith(b"HTTP/1.1 431")
    idle = [socket.create_connection(("127.0.0.1", gate.port), timeout=10) for _ in range(CLIENTS_MAX)]
    try:
        with socket.create_connection(("127.0.0.1", gate.port), timeout=10) as s:
            assert s.recv(100).startswith(b"HTTP/1.1 503")
    finally:
        for s in idle:
            s.close()
    with connect(f"ws://127.0.0.1:{gate.port}", subprotocols=[SDK], open_timeout=30) as ws:  # type: ignore[list-item]
        assert ws.subprotocol == SDK


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300), st.lists(st.sampled_from([SDK, WEBSOCKET, "x", "", " , "]), max_size=3))
def test_any_head_is_forwarded_with_the_sdks_name_or_refused_never_raises(junk: bytes, offered: list[str]) -> None:
    head = junk + b"\r\n" + _head(*offered)
    forward, name, refused = rewrite_head(head)
    if SDK in offered or WEBSOCKET in offered:
        assert not refused
        assert b"Sec-WebSocket-Protocol: " + SDK.encode() in forward or forward == head
        assert name == (None if forward == head else WEBSOCKET)
    else:
        assert refused.startswith(b"HTTP/1.1 400") or SDK.encode() in junk or WEBSOCKET.encode() in junk
