"""The viewer's WebSocket from a raw client: hostile commands are refused with a reason, and the
server goes on answering."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from websockets.sync.client import ClientConnection, connect

from tests.integration.browser import viewer_url
from tests.integration.harness import ROOT, Net

pytestmark = [pytest.mark.timeout(120)]

SAMPLE = ROOT / "recordings" / "demo-sample.mcap"


@pytest.fixture
def socket_url(tmp_path: Path) -> Iterator[str]:
    """``iwz view`` replaying the sample recording; its WebSocket's address."""
    net = Net(tmp_path, sim="default")
    try:
        yield (
            viewer_url(net.spawn("view", str(SAMPLE), "--port", "0", "--no-foxglove", connect=False)).replace(
                "http://", "ws://"
            )
            + "ws"
        )
    finally:
        net.close()


def _next_error(ws: ClientConnection) -> str:
    """The next ``error`` the server sends (every other message skipped)."""
    while True:
        msg = json.loads(ws.recv(timeout=30))
        if msg["type"] == "error":
            return str(msg["error"])


@pytest.mark.parametrize(
    ("sent", "says"),
    [
        (b"\x00\x01binary", "a command is a JSON text message, not binary"),
        ("not json", "JSON is malformed"),
        ("[]", "Expected `object`, got `array`"),
        ('{"cmd": "step", "steps": -1}', "Expected `int` >= 1 - at `$.steps`"),
        ('{"cmd": "pause", "extra": 1}', "unknown field `extra`"),
        ('{"cmd": "scans", "scans": "mine"}', "Invalid enum value 'mine' - at `$.scans`"),
    ],
)
def test_a_hostile_command_is_refused_with_a_reason_and_the_server_answers_on(
    socket_url: str, sent: str | bytes, says: str
) -> None:
    with connect(socket_url, open_timeout=30) as ws:
        ws.send(sent)
        assert says in _next_error(ws)
        ws.send('{"cmd": "rate", "rate": -1}')  # still answering, the same connection
        assert "Expected `float` >= 0.0" in _next_error(ws)
