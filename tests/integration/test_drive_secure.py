"""Driving from the page in a secured run (real certificates, a router enforcing the policy over
mutual TLS, world, collision, sensors, two ``manual`` chairs and ``iwz view``, each its own
process, and Debian's Chromium): the viewer's identity may drive chair 1 only, so the page drives
chair 1 and is refused chair 2 with the reason; and the viewer's certificate itself cannot put an
input on chair 2's drive key (the router drops it), whatever a modified viewer would do."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import NetConfig
from iw_zenoh.messages import DriveInput, DriveState, WorldState, encode
from iw_zenoh.secure.certs import init_ca, issue
from iw_zenoh.secure.cli import add_identity
from tests.integration.browser import viewer_url
from tests.integration.harness import Net, Proc, subscribe, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

SIM = "secdrive"
LAB = '<Lab Name="open" Width="20" Height="10"/>'
GRID = '<Grid><Position X="4" Y="3" Dir="0"/><Position X="4" Y="7" Dir="0"/></Grid>'
ROLES = {"world": "world", "collision": "collision", "sensors": "sensors", "observer": "recorder"}
WAIT_MS = 30_000


class Secured:
    def __init__(self, net: Net, ids: Path, endpoint: str, url: str) -> None:
        self.net, self.ids, self.endpoint, self.url = net, ids, endpoint, url

    def session(self, identity: str) -> ZenohBus:
        bus = ZenohBus(NetConfig(connect=(self.endpoint,), identity=str(self.ids / identity)))
        self.net.buses.append(bus)
        return bus


def _identities(ids: Path) -> None:
    init_ca(ids)
    issue(ids, "router", server=True)
    for name, role in ROLES.items():
        issue(ids, name)
        add_identity(ids / "policy.toml", name, [role])
    for name, chair in (("chair1", 1), ("chair2", 2)):
        issue(ids, name)
        add_identity(ids / "policy.toml", name, ["agent"], robots=[chair])
    issue(ids, "seat")
    add_identity(ids / "policy.toml", "seat", ["viewer"], robots=[1])  # its pages may drive chair 1 only
    text = (ids / "policy.toml").read_text().replace('sim = "default"', f'sim = "{SIM}"')
    (ids / "policy.toml").write_text(text)


def _spawn(net: Net, ids: Path, endpoint: str, name: str, *args: str) -> Proc:
    argv = [sys.executable, "-m", "iw_zenoh.cli", *args, "--sim", SIM, "--name", name]
    return net.launch(name, [*argv, "--identity", str(ids / name), "-e", endpoint])


@pytest.fixture(scope="module")
def secured(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Secured]:
    tmp = tmp_path_factory.mktemp("secdrive")
    ids = tmp / "ids"
    _identities(ids)
    (tmp / "lab.xml").write_text(LAB)
    (tmp / "grid.xml").write_text(GRID)
    net = Net(tmp, sim=SIM)
    try:
        net.start_secured_router(ids)
        endpoint = net.endpoint
        lab = [str(tmp / "lab.xml"), "--grid", str(tmp / "grid.xml"), "--policy", str(ids / "policy.toml")]
        _spawn(net, ids, endpoint, "world", "world", *lab)
        _spawn(net, ids, endpoint, "collision", "collision")
        _spawn(net, ids, endpoint, "sensors", "sensors")
        for name, chair in (("chair1", "1"), ("chair2", "2")):
            _spawn(net, ids, endpoint, name, "agent", "manual", "--id", chair)
        url = viewer_url(_spawn(net, ids, endpoint, "seat", "view", "--port", "0", "--no-foxglove"))
        s = Secured(net, ids, endpoint, url)
        obs = s.session("observer")
        wait_msg(subscribe(obs, keys.state(SIM)), WorldState, lambda m: {1, 2} <= set(m.ids), timeout_s=90)
        yield s
    finally:
        net.close()


def test_a_secured_page_drives_the_chair_its_viewer_is_granted_and_is_refused_another(
    secured: Secured, browser: Browser
) -> None:
    obs = secured.session("observer")
    driving2 = subscribe(obs, keys.driving(SIM, 2))
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.goto(f"{secured.url}?drive=2")
    page.wait_for_function(
        "document.getElementById('drive-status').textContent.includes('may not drive chair 2')", timeout=WAIT_MS
    )
    said = page.inner_text("#drive-status")
    assert "'seat'" in said, said
    assert "grants it chairs [1]" in said, said
    for _ in range(5):  # five ticks of chair 2's state later: nobody drives it
        assert wait_msg(driving2, DriveState).driver == ""

    driving1 = subscribe(obs, keys.driving(SIM, 1))
    page.goto(f"{secured.url}?drive=1")
    page.wait_for_function(
        "document.getElementById('drive-status').textContent.startsWith('you drive')", timeout=WAIT_MS
    )
    page.keyboard.down("ArrowUp")
    wait_msg(driving1, DriveState, lambda d: d.driver.startswith("seat#") and d.input_v_mps > 0)
    page.keyboard.up("ArrowUp")
    page.close()


def test_the_viewers_certificate_cannot_put_an_input_on_a_chair_it_is_not_granted(secured: Secured) -> None:
    seat = secured.session("seat")  # as a viewer modified to skip its own check would
    obs = secured.session("observer")
    driving2 = subscribe(obs, keys.driving(SIM, 2))
    seen = subscribe(obs, keys.drive(SIM, 2))
    push = DriveInput(robot_id=2, driver="seat#99", x=0.0, y=1.0, buttons=1, level=5, take=True)
    for _ in range(10):  # half a second of input at 20 Hz, and each of chair 2's states in that time
        seat.publish(keys.drive(SIM, 2), encode(push))
        assert wait_msg(driving2, DriveState).driver == ""
    assert seen.drain() == []  # the router delivered none of it
