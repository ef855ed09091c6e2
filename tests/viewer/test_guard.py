"""The viewer's edge: who gets in (Origin, Host, keys), what a page may send (every command with
hostile values, and hypothesis's), at what rate; and a command that raises on the pump answered
with an error while the pump goes on."""

from __future__ import annotations

import queue
import threading

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from iw_zenoh.bus import Inbox
from iw_zenoh.messages import Control, decode
from iw_zenoh.messages.page import PageCommand, PageError, PageHello, PageMessage
from iw_zenoh.viewer.feed import Feed
from iw_zenoh.viewer.guard import Access, Rate, check_command, is_loopback
from iw_zenoh.viewer.server import Client, Pump
from iw_zenoh.viewer.sources import LiveSource, LocalBus

CMDS = ["start", "pause", "step", "stop", "remove", "add_obstacle", "move_obstacle", "remove_obstacle"]
CMDS += ["reading", "seek", "rate", "scans"]
_DECODE = msgspec.json.Decoder(PageCommand)


def _access(host: str = "127.0.0.1") -> Access:
    return Access(host, port=8080, watch_key="w" * 24, steer_key="s" * 24)


@pytest.mark.parametrize(
    ("host", "origin", "key", "right"),
    [
        ("127.0.0.1:8080", None, None, "steer"),  # this machine, no browser page
        ("localhost:8080", "http://localhost:8080", None, "steer"),  # the page's own origin
        ("[::1]:8080", "http://[::1]:8080", None, "steer"),
        ("127.0.0.1:8080", "http://evil.example", None, ""),  # another site's page
        ("127.0.0.1:8080", "http://evil.example", "s" * 24, ""),  # ... even with the key
        ("evil.example:8080", "http://evil.example:8080", None, ""),  # DNS rebinding
        ("evil.example:8080", None, None, ""),
        ("127.0.0.1:9999", None, None, ""),  # another port's name
        ("", None, None, ""),
        ("tunnel.example:8080", "http://tunnel.example:8080", "s" * 24, "steer"),  # another name, with the key
        ("tunnel.example:8080", None, "w" * 24, "watch"),
        ("127.0.0.1:8080", None, "guessed", ""),
        ("127.0.0.1:8080", "null", None, ""),  # a sandboxed iframe, a data: or file: page of any site
        ("localhost:8080", "null", None, ""),
        ("127.0.0.1:8080", "null", "guessed", ""),
        ("127.0.0.1:8080", "null", "w" * 24, "watch"),  # ... with the key it printed
        ("127.0.0.1:8080", "file://", None, ""),  # a file: page, in a browser that names it
        ("127.0.0.1:8080", "file:///home/u/evil.html", "s" * 24, ""),
    ],
)
def test_a_loopback_viewer_lets_in_its_own_origin_or_a_key(
    host: str, origin: str | None, key: str | None, right: str
) -> None:
    got, why = _access().right(host, origin, key)
    assert got == right
    assert bool(why) != bool(right)


@pytest.mark.parametrize("host", ["0.0.0.0", "10.0.0.5", "::", "example.org"])
def test_a_viewer_on_the_network_lets_in_nobody_without_a_key(host: str) -> None:
    a = _access(host)
    assert not a.local
    for h in ("127.0.0.1:8080", "localhost:8080", f"{host}:8080"):
        right, why = a.right(h, None, None)
        assert right == ""
        assert "key" in why
    assert a.right("10.0.0.5:8080", "http://10.0.0.5:8080", "w" * 24)[0] == "watch"
    assert a.right("10.0.0.5:8080", "http://10.0.0.5:8080", "s" * 24)[0] == "steer"
    watch, steer = a.addresses("10.0.0.5")
    assert watch.endswith("w" * 24)
    assert steer.endswith("s" * 24)


def test_keys_differ_each_start_and_loopback_names_are_known() -> None:
    a, b = Access("0.0.0.0"), Access("0.0.0.0")
    assert len({a.watch_key, a.steer_key, b.watch_key, b.steer_key}) == 4
    assert all(is_loopback(h) for h in ("127.0.0.1", "127.1.2.3", "::1", "[::1]", "localhost"))
    assert not any(is_loopback(h) for h in ("0.0.0.0", "::", "10.0.0.1", "evil.example"))


def test_a_watch_page_may_only_read() -> None:
    for c in CMDS:
        cmd = PageCommand(cmd=c)  # type: ignore[arg-type]
        why = check_command(cmd, "watch")
        assert (why == "") == (c in ("reading", "scans")), c
        assert check_command(cmd, "steer") == ""


HOSTILE_VALUES = [
    99999999999999999999,
    2**63,
    2**64,
    -1,
    -(2**63) - 1,
    1e308,
    -1e308,
    "1",
    "x" * 10_000,
    None,
    True,
    [],
    {},
    [1, 2],
    {"name": "a"},
]
FIELDS = ["robot_id", "steps", "at_ns", "rate", "scans", "obstacle", "cmd", "extra"]


def _obstacle(**over: object) -> dict[str, object]:
    ob: dict[str, object] = {"name": "o", "x0": 1.0, "y0": 1.0, "x1": 2.0, "y1": 2.0, "height": 1.0}
    ob.update(over)
    return ob


HOSTILE_OBSTACLES = [
    _obstacle(name=""),
    _obstacle(name="x" * 65),
    _obstacle(name="a\nb"),
    _obstacle(name="\x00"),
    _obstacle(x0=1e300),
    _obstacle(y1=-1e6),
    _obstacle(height=0),
    _obstacle(height=-1),
    _obstacle(height=1e9),
    _obstacle(extra=1),
    _obstacle(x0="1"),
]


def _through_the_edge(raw: bytes) -> str:
    """A page's message as the server takes it: refused at the edge (why), or carried out by a live
    source whose control must then be a valid ``Control`` ("" then)."""
    try:
        cmd = _DECODE.decode(raw)
    except msgspec.DecodeError as e:
        return str(e) or "refused"
    if why := check_command(cmd, "steer"):
        return why
    out = Inbox()
    source = LiveSource(LocalBus(out), "s", threading.Event())
    source.command(cmd)  # must not raise
    for _, data, *_ in out.drain():
        decode(data, Control)  # what went to the world is valid
    return ""


@pytest.mark.parametrize("cmd", CMDS)
def test_every_hostile_value_in_every_field_of_every_command_is_refused_or_harmless(cmd: str) -> None:
    for field in FIELDS:
        for v in HOSTILE_VALUES:
            msg = {"cmd": cmd, field: v} if field != "cmd" else {"cmd": v}
            _through_the_edge(msgspec.json.encode(msg))
    for ob in HOSTILE_OBSTACLES:
        assert _through_the_edge(msgspec.json.encode({"cmd": cmd, "obstacle": ob})), (cmd, ob)
    for big in ('{"cmd":"%s","robot_id":99999999999999999999}', '{"cmd":"%s","at_ns":1e400}'):
        assert _through_the_edge((big % cmd).encode())


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=10), inner, max_size=4),
    max_leaves=12,
)


@settings(max_examples=300, deadline=None)
@given(
    cmd=st.sampled_from(CMDS) | st.text(max_size=8),
    fields=st.dictionaries(st.sampled_from([*FIELDS, "name"]), JSON, max_size=4),
    ob=st.fixed_dictionaries(
        {k: st.floats() | st.integers() | st.text(max_size=70) for k in ("name", "x0", "y0", "x1", "y1", "height")}
    ),
)
def test_fuzzed_page_messages_never_raise_past_the_edge(
    cmd: str, fields: dict[str, object], ob: dict[str, object]
) -> None:
    _through_the_edge(msgspec.json.encode({"cmd": cmd, **fields}))
    _through_the_edge(msgspec.json.encode({"cmd": cmd, "obstacle": ob}))


@given(raw=st.binary(max_size=200))
@settings(max_examples=200, deadline=None)
def test_fuzzed_bytes_never_raise_past_the_edge(raw: bytes) -> None:
    _through_the_edge(raw)


def test_a_flooding_page_is_refused_past_its_rate_and_told_once_a_second() -> None:
    r = Rate(per_s=20, burst=40)
    taken = sum(r.take(0.0) for _ in range(1000))
    assert taken == 40
    assert "960 dropped" in r.tell(0.0)
    assert r.tell(0.5) == ""  # told at most once a second
    assert r.take(0.6)  # refilled at 20 a second
    assert r.tell(1.2)


class _Breaks:
    """A source whose every command raises (a fault not foreseen at the edge)."""

    live = True
    sim = "s"

    def poll(self, feed: Feed, now: int) -> list[PageMessage]:
        return []

    def command(self, cmd: PageCommand) -> str:
        raise msgspec.ValidationError("Expected `int` <= 9223372036854775807 - at `$.robot_id`")

    def extra(self) -> list[PageMessage]:
        return []

    def close(self) -> None:
        """Nothing."""


def test_a_command_that_raises_on_the_pump_is_answered_with_an_error_and_the_pump_goes_on() -> None:
    got: queue.SimpleQueue[list[str]] = queue.SimpleQueue()
    wake = threading.Event()
    pump = Pump(_Breaks(), Feed("s"), wake, lambda c, data, snap: got.put([d for d in data if isinstance(d, str)]))
    pump.start()
    try:
        page = Client(ws=None, right="watch")  # type: ignore[arg-type]
        pump.ask(page, PageCommand(cmd="pause"))
        error = msgspec.json.decode(got.get(timeout=10)[0], type=PageMessage)
        assert isinstance(error, PageError)
        assert "robot_id" in error.error
        pump.ask(page, None)  # still answering: a page that joins gets its hello
        hello = msgspec.json.decode(got.get(timeout=10)[0], type=PageMessage)
        assert isinstance(hello, PageHello)
        assert hello.steer is False
        assert pump.is_alive()
    finally:
        pump.stop.set()
        wake.set()
        pump.join(5)
