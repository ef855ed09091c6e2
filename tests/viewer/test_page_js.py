"""The page's JavaScript kept honest without a browser: every module type-checked by its
``// @ts-check`` header, ``types.js`` declaring each page message with the fields
``iw_zenoh/messages/page.py`` gives it, and no test or benchmark hook outside ``hooks.js``
(which the page loads only when its address says ``?hooks=1``)."""

from __future__ import annotations

import re
from pathlib import Path

import msgspec
import pytest

from iw_zenoh.messages import page
from iw_zenoh.viewer.server import STATIC

SCRIPTS = sorted(STATIC.glob("*.js"))
TYPES = (STATIC / "types.js").read_text()
# the page's own structs besides the tagged messages
PLAIN = (page.PageSensor, page.PageLaser, page.PageRobot, page.PageWall, page.TimelineMark)


def _typedef(name: str) -> list[str]:
    """The property names of ``types.js``'s typedef ``name``."""
    m = re.search(r"@typedef \{object\} " + name + r"\b(.*?)\*/", TYPES, re.S)
    assert m, f"types.js has no typedef {name}"
    return re.findall(r"@property \{.*\} \[?(\w+)", m.group(1))  # (a type may hold braces: greedy to the last)


def _structs() -> list[type[msgspec.Struct]]:
    return [*page.PageMessage.__args__, *PLAIN]


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_every_module_of_the_page_is_type_checked(script: Path) -> None:
    assert script.read_text().startswith("// @ts-check\n"), f"{script.name}: its first line must be // @ts-check"


@pytest.mark.parametrize("struct", _structs(), ids=lambda s: s.__name__)
def test_types_js_declares_each_page_message_with_its_fields(struct: type[msgspec.Struct]) -> None:
    fields = list(struct.__struct_fields__)
    tag = struct.__struct_config__.tag
    want = (["type"] if tag else []) + fields
    assert _typedef(struct.__name__) == want, f"types.js's {struct.__name__} differs from messages/page.py's"


def test_types_js_declares_the_page_command_with_its_fields() -> None:
    assert sorted(_typedef("PageCommand")) == sorted(page.PageCommand.__struct_fields__)


def test_no_hook_for_tests_or_benchmarks_outside_hooks_js() -> None:
    for script in SCRIPTS:
        if script.name == "hooks.js":
            continue
        text = script.read_text()
        assert "window.iwz" not in text, f"{script.name} sets a test hook: it belongs in hooks.js"
    app = (STATIC / "app.js").read_text()
    assert re.search(r'get\("hooks"\) === "1"\)\s*\{\s*import\("\./hooks\.js"\)', app), "hooks.js only behind ?hooks=1"


def test_only_world_js_writes_the_shared_world() -> None:
    for script in SCRIPTS:
        if script.name == "world.js":
            continue
        writes = re.findall(r"\bworld\.\w+(?:\.\w+)*\s*(?:=(?!=)|\+=|-=|\+\+)", script.read_text())
        assert not writes, f"{script.name} writes the world ({writes}): world.js owns it"
