"""The gate of Foxglove live in front of a real foxglove-sdk server: both subprotocol names are
served, anything else is refused with the served names, hostile handshakes cost a bounded amount."""

from __future__ import annotations

import gc
import socket
import warnings
from collections.abc import Iterator

import foxglove
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from websockets.exceptions import InvalidStatus
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Origin, Subprotocol

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


def _from(port: int, protocol: str, origin: str) -> ClientConnection:
    """A WebSocket client of the gate offering ``protocol``, as a page of ``origin``."""
    return connect(
        f"ws://127.0.0.1:{port}", subprotocols=[Subprotocol(protocol)], origin=Origin(origin), open_timeout=10
    )


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
    if b"origin" in junk.lower():
        return  # a junk Origin header may be refused (403): any outcome but raising
    if SDK in offered or WEBSOCKET in offered:
        assert not refused
        assert b"Sec-WebSocket-Protocol: " + SDK.encode() in forward or forward == head
        assert name == (None if forward == head else WEBSOCKET)
    else:
        assert refused.startswith(b"HTTP/1.1 400") or SDK.encode() in junk or WEBSOCKET.encode() in junk


@pytest.mark.parametrize(
    "origin",
    [
        "https://evil.example",
        "http://evil.example:8765",  # DNS rebinding: the attacker's name resolved to 127.0.0.1
        "null",  # a sandboxed iframe, a data: page: any site's
        "https://app.foxglove.dev.evil.example",
        "http://127.0.0.1.evil.example",
    ],
)
def test_another_sites_page_is_refused_with_the_flag_that_lets_it_in(gate: FoxgloveGate, origin: str) -> None:
    with pytest.raises(InvalidStatus) as e:
        _from(gate.port, WEBSOCKET, origin)
    assert e.value.response.status_code == 403
    why = e.value.response.body.decode()
    assert "may not read this run" in why
    assert "--allow-origin" in why
    assert "--foxglove-allow-origin" in why
    with connect(f"ws://127.0.0.1:{gate.port}", subprotocols=[SDK], open_timeout=10) as ws:  # type: ignore[list-item]
        assert '"op":"serverInfo"' in str(ws.recv(timeout=10)).replace(" ", "")  # the others go on


@pytest.mark.parametrize(
    "origin",
    [
        "https://app.foxglove.dev",  # Foxglove's web app
        "file://",  # Foxglove's and Lichtblick's desktop apps (Electron)
        "http://127.0.0.1:8080",  # the page of iwz view, a local Lichtblick
        "http://localhost:8080",
        "http://[::1]:3000",
    ],
)
def test_the_apps_and_loopback_pages_are_served(gate: FoxgloveGate, origin: str) -> None:
    with _from(gate.port, WEBSOCKET, origin) as ws:
        assert ws.subprotocol == WEBSOCKET
        assert '"op":"serverInfo"' in str(ws.recv(timeout=10)).replace(" ", "")


def test_an_origin_the_user_adds_is_served() -> None:
    server = foxglove.start_server(host="127.0.0.1", port=0, context=foxglove.Context())
    g = FoxgloveGate("127.0.0.1", 0, server.port, allow_origins=["https://Lichtblick.example/"])
    try:
        with _from(g.port, SDK, "https://lichtblick.example") as ws:
            assert ws.subprotocol == SDK
        with pytest.raises(InvalidStatus):
            _from(g.port, SDK, "https://other.example")
    finally:
        g.close()
        server.stop()


def test_a_taken_port_is_refused_and_leaves_no_event_loop_open() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ResourceWarning)
            for _ in range(3):
                with pytest.raises(OSError, match="in use"):
                    FoxgloveGate("127.0.0.1", taken.getsockname()[1], 1)
            gc.collect()
    assert not [w for w in caught if "unclosed event loop" in str(w.message)]
