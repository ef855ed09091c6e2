"""The viewer's WebSocket from a raw client: hostile commands are refused with a reason, and the
server goes on answering."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from websockets.exceptions import InvalidStatus
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


def test_pages_past_the_cap_are_refused_with_503_and_why_until_one_closes(tmp_path: Path) -> None:
    net = Net(tmp_path, sim="default")
    try:
        view = net.spawn("view", str(SAMPLE), "--port", "0", "--no-foxglove", "--max-pages", "2", connect=False)
        url = viewer_url(view).replace("http://", "ws://") + "ws"
        with connect(url, open_timeout=30) as first:
            with connect(url, open_timeout=30) as second:
                with pytest.raises(InvalidStatus) as refused, connect(url, open_timeout=30):
                    pass
                assert refused.value.response.status_code == 503
                assert b"at most 2 pages at once" in refused.value.response.body
                for page in (first, second):
                    assert json.loads(page.recv(timeout=30))["type"]  # the open pages are served on
            deadline = time.monotonic() + 30
            while True:  # the server notices the page that closed; then the next is let in
                try:
                    with connect(url, open_timeout=30) as third:
                        assert json.loads(third.recv(timeout=30))["type"]
                    break
                except InvalidStatus:
                    assert time.monotonic() < deadline, "a page closed but the next was still refused after 30 s"
        assert "refused a page from 127.0.0.1: the viewer serves at most 2 pages at once" in view.output()
    finally:
        net.close()


def test_a_cap_of_no_pages_is_refused_saying_what_to_give(tmp_path: Path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", "view", str(SAMPLE), "--max-pages", "0"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2, r.stdout + r.stderr
    assert "--max-pages 0: give 1 or more" in r.stdout + r.stderr
