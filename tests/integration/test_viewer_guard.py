"""``iwz view`` attacked as a user's browser and a LAN would: a WebSocket with a foreign Origin, a
foreign Host (DNS rebinding), a page command with a 20-digit id, and a second machine (network
namespace) on a ``--host`` viewer without and with its keys."""

from __future__ import annotations

import base64
import http.client
import json
import os
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import sync_playwright
from websockets.sync.client import ClientConnection, connect

from benchmarks.chromium import CHROMIUM, FLAGS, INSTALL
from tests.integration import netns
from tests.integration.browser import hooked, viewer_url
from tests.integration.harness import ROOT, Net, start_world

pytestmark = [pytest.mark.timeout(180)]

SAMPLE = ROOT / "recordings" / "demo-sample.mcap"


def _handshake(url: str, host: str | None = None, origin: str | None = None, path: str = "/ws") -> int:
    """The status a WebSocket handshake (a browser's, with these ``Host`` and ``Origin``) gets."""
    m = re.match(r"http://([^/:]+):(\d+)/", url)
    assert m, url
    conn = http.client.HTTPConnection(m.group(1), int(m.group(2)), timeout=30)
    try:
        headers = {
            "Host": host or f"{m.group(1)}:{m.group(2)}",
            "Upgrade": "websocket",
            "Connection": "Upgrade",
            "Sec-WebSocket-Key": base64.b64encode(os.urandom(16)).decode(),
            "Sec-WebSocket-Version": "13",
        }
        if origin is not None:
            headers["Origin"] = origin
        conn.request("GET", path, headers=headers)
        return conn.getresponse().status
    finally:
        conn.close()


@pytest.fixture
def replay_url(tmp_path: Path) -> Iterator[str]:
    """``iwz view`` replaying the sample recording, on loopback; its page's address."""
    net = Net(tmp_path, sim="default")
    try:
        yield viewer_url(net.spawn("view", str(SAMPLE), "--port", "0", "--no-foxglove", connect=False))
    finally:
        net.close()


def test_a_foreign_origin_or_host_is_refused_with_403_and_the_pages_own_origin_is_served(replay_url: str) -> None:
    port = replay_url.rsplit(":", 1)[1].strip("/")
    assert _handshake(replay_url, origin="http://evil.example") == 403  # any site's page, in the user's browser
    assert _handshake(replay_url, origin=f"http://evil.example:{port}") == 403
    assert _handshake(replay_url, host=f"evil.example:{port}", origin=f"http://evil.example:{port}") == 403  # rebinding
    assert _handshake(replay_url, host=f"evil.example:{port}", path="/") == 403  # nor the page
    assert _handshake(replay_url, host=f"127.0.0.1:{int(port) + 1}") == 403  # another port's name
    for name in ("127.0.0.1", "localhost", "[::1]"):  # the page's own origin, by each loopback name
        assert _handshake(replay_url, host=f"{name}:{port}", origin=f"http://{name}:{port}") == 101
    assert _handshake(replay_url) == 101  # a client that is no browser's page (no Origin)


def test_in_chromium_the_pages_own_origin_steers_a_rebound_name_and_another_sites_socket_are_refused(
    tmp_path: Path,
) -> None:
    net = Net(tmp_path, sim="default")
    try:
        url = viewer_url(net.spawn("view", str(SAMPLE), "--port", "0", "--no-foxglove", connect=False))
        port = url.rsplit(":", 1)[1].strip("/")
        if not CHROMIUM.exists():
            pytest.fail(f"{CHROMIUM} is missing: install it with `{INSTALL}`")
        with sync_playwright() as pw:  # the attacker's name resolves to this machine, as DNS rebinding makes it
            browser = pw.chromium.launch(
                executable_path=str(CHROMIUM), args=[*FLAGS, "--host-resolver-rules=MAP evil.example 127.0.0.1"]
            )
            try:
                page = browser.new_page()
                page.goto(hooked(url))  # its own origin: the page joins, may steer, and its pause is obeyed
                page.wait_for_function("window.iwz && window.iwz.world.timeline", timeout=60_000)
                assert page.is_visible("#btn-pause")
                page.click("#btn-start")
                page.wait_for_function("window.iwz.world.timeline.playing === true", timeout=60_000)
                page.click("#btn-pause")
                page.wait_for_function("window.iwz.world.timeline.playing === false", timeout=60_000)

                rebound = browser.new_page()
                resp = rebound.goto(f"http://evil.example:{port}/")
                assert resp is not None
                assert resp.status == 403
                assert "DNS rebinding" in rebound.content()

                evil = browser.new_page()  # another site's page (any file it serves) opening the viewer's socket
                evil.goto(f"http://evil.example:{port}/static/style.css")
                outcome = evil.evaluate(
                    """(url) => new Promise((done) => {
                        const ws = new WebSocket(url);
                        ws.onopen = () => done("open");
                        ws.onclose = () => done("refused");
                    })""",
                    f"ws://127.0.0.1:{port}/ws",
                )
                assert outcome == "refused"
            finally:
                browser.close()
    finally:
        net.close()


def _frames(ws: ClientConnection, count: int, timeout_s: float = 30.0) -> list[int]:
    """The ticks of the next ``count`` frames on a page (other messages skipped)."""
    ticks: list[int] = []
    deadline = time.monotonic() + timeout_s
    while len(ticks) < count:
        msg = json.loads(ws.recv(timeout=max(0.1, deadline - time.monotonic())))
        if msg["type"] == "frame":
            ticks.append(msg["tick"])
    return ticks


def _error(ws: ClientConnection, timeout_s: float = 30.0) -> str:
    while True:
        msg = json.loads(ws.recv(timeout=timeout_s))
        if msg["type"] == "error":
            return str(msg["error"])


@pytest.mark.zenoh
def test_a_20_digit_id_is_refused_to_that_page_only_and_every_page_keeps_its_frames(tmp_path: Path) -> None:
    net = Net(tmp_path, sim="guard")
    net.start_router()
    try:
        start_world(net)
        ws_url = viewer_url(net.spawn("view", "--port", "0", "--no-foxglove")).replace("http://", "ws://") + "ws"
        with connect(ws_url, open_timeout=30) as hostile, connect(ws_url, open_timeout=30) as other:
            _frames(other, 2)
            for bad in (
                '{"cmd":"remove","robot_id":99999999999999999999}',
                '{"cmd":"reading","robot_id":18446744073709551616}',
                '{"cmd":"remove","robot_id":9223372036854775808}',
            ):
                hostile.send(bad)
                assert "robot_id" in _error(hostile)
            before = _frames(other, 1)[0]
            assert _frames(other, 3)[-1] > before, "the other page froze"
            assert _frames(hostile, 2), "the page that sent it is served on"
    finally:
        net.close()


def _client_in(ns: str, url: str, commands: list[str]) -> dict[str, object]:
    """A WebSocket client on the other host: the handshake's status, the hello, the answers."""
    script = f"""
import json, sys
from websockets.sync.client import connect
from websockets.exceptions import InvalidStatus
out = {{}}
try:
    with connect({url!r}, open_timeout=30) as ws:
        hello = json.loads(ws.recv(timeout=30))
        out["hello"] = hello
        errors = []
        for c in {commands!r}:
            ws.send(c)
        ws.send('{{"cmd":"rate","rate":-1}}')  # a marker: its refusal comes after every answer above
        while True:
            m = json.loads(ws.recv(timeout=30))
            if m["type"] == "error":
                if "Expected `float` >= 0.0" in m["error"]:
                    break
                errors.append(m["error"])
        out["errors"] = errors
except InvalidStatus as e:
    out["status"] = e.response.status_code
    out["body"] = e.response.body.decode()
print(json.dumps(out))
"""
    r = subprocess.run(
        ["ip", "netns", "exec", ns, sys.executable, "-c", script], capture_output=True, text=True, timeout=90, cwd=ROOT
    )
    assert r.returncode == 0, r.stdout + r.stderr
    return dict(json.loads(r.stdout.strip().splitlines()[-1]))


@pytest.mark.zenoh
def test_a_second_machine_needs_the_printed_key_and_only_the_steer_key_steers(tmp_path: Path) -> None:
    with netns.two_hosts("v", "10.231.150") as (ns_a, ns_b, addr):
        net = Net(tmp_path, sim="default")
        try:
            view = net.spawn(
                "view", str(SAMPLE), "--host", addr, "--port", "0", "--no-foxglove",
                connect=False, prefix=["ip", "netns", "exec", ns_a],
            )  # fmt: skip
            deadline = time.monotonic() + 60
            while not (m := re.search(r"STEER \(.*\) (http://\S+)", view.output())):
                assert view.popen.poll() is None, view.output()
                assert time.monotonic() < deadline, view.output()
                time.sleep(0.05)  # polling its log: there is no event to wait on
            out = view.output()
            assert "WARNING" in out
            assert "open to the network" in out
            watch = re.search(r"WATCH \(read-only\) (http://\S+)", out)
            assert watch, out
            steer_ws = m.group(1).replace("http://", "ws://").replace("/?key=", "/ws?key=")
            watch_ws = watch.group(1).replace("http://", "ws://").replace("/?key=", "/ws?key=")
            bare = steer_ws.split("?")[0]

            refused = _client_in(ns_b, bare, [])
            assert refused.get("status") == 403, refused
            assert "key" in str(refused["body"])
            wrong = _client_in(ns_b, bare + "?key=guessed", [])
            assert wrong.get("status") == 403, wrong

            watcher = _client_in(ns_b, watch_ws, ['{"cmd":"pause"}', '{"cmd":"reading","robot_id":1}'])
            assert watcher["hello"]["steer"] is False  # type: ignore[index]
            assert any("may only watch" in e for e in list(watcher["errors"])), watcher  # type: ignore[call-overload]

            steerer = _client_in(ns_b, steer_ws, ['{"cmd":"pause"}', '{"cmd":"seek","at_ns":0}'])
            assert steerer["hello"]["steer"] is True  # type: ignore[index]
            assert steerer["errors"] == [], steerer
        finally:
            net.close()
