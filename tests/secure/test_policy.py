from __future__ import annotations

import json

import pytest
import zenoh

from iw_zenoh.errors import ConfigError
from iw_zenoh.secure.grants import POLICY_ROLES, grants
from iw_zenoh.secure.policy import access_control, owners, parse_policy

POLICY = """
sim = "s"
[identities.world]
role = "world"
[identities.alice]
role = "agent"
robots = [1, 2]
[identities."sensors-1"]
role = "sensors"
shard = "1/2"
[identities.legacy]
role = ["bridge", "operator"]
"""


def _puts(roles: tuple[str, ...], **kw: object) -> set[str]:
    return set(grants(roles, "s", name=kw.pop("name", "n"), **kw).put)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("role", "only"),
    [
        ("world", {"iw/s/world/tick", "iw/s/world/proposed", "iw/s/world/state", "iw/s/world/info"}),
        ("collision", {"iw/s/world/verdict"}),
        ("sensors", {"iw/s/world/sensors/*", "iw/s/robot/*/sensors"}),
        ("radio", {"iw/s/robot/*/hear", "iw/s/world/radio"}),
        ("operator", {"iw/s/world/control"}),
    ],
)
def test_each_key_of_the_simulation_is_published_by_its_role_alone(role: str, only: set[str]) -> None:
    others = set().union(*(_puts((r,)) for r in POLICY_ROLES if r != role))
    assert only <= _puts((role,))
    assert not only & others


def test_an_agent_publishes_only_for_its_own_robots_and_its_own_batch() -> None:
    puts = _puts(("agent",), name="alice", robots=(1, 2))
    assert puts == {
        "iw/s/agent/alice/actions",
        "iw/s/events/bad-message",
        *(f"iw/s/robot/{r}/{k}" for r in (1, 2) for k in ("actions", "say", "pose_report", "driving", "drive")),
    }


def test_an_agent_registers_only_on_its_own_key_and_only_the_world_answers() -> None:
    g = grants(("agent",), "s", name="alice", robots=(1,))
    assert g.query == ("iw/s/world/info", "iw/s/world/register/alice")
    assert g.serve == ()
    assert grants(("world",), "s", name="world").serve == ("iw/s/world/register/**", "iw/s/world/info")


def test_the_recorder_and_a_viewer_only_read() -> None:
    for role in ("recorder", "viewer"):
        g = grants((role,), "s", name="r")
        assert g.read == ("iw/s/**",)
        assert not {k for k in g.put if "/events/" not in k}


def test_a_sensors_shard_publishes_only_its_own_batch() -> None:
    assert "iw/s/world/sensors/1-2" in _puts(("sensors",), shard=(1, 2))
    assert "iw/s/world/sensors/*" not in _puts(("sensors",), shard=(1, 2))


def test_the_router_config_denies_by_default_and_names_each_identity_by_its_certificate() -> None:
    acl = access_control(parse_policy(POLICY))
    assert (acl["enabled"], acl["default_permission"]) == (True, "deny")
    assert {s["id"]: s["cert_common_names"] for s in acl["subjects"]} == {
        n: [n] for n in ("world", "alice", "sensors-1", "legacy")
    }
    rules = {r["id"]: r for r in acl["rules"]}
    assert rules["alice/put"]["flows"] == ["ingress"]
    assert "iw/s/world/control" in rules["legacy/put"]["key_exprs"]
    assert all(r["permission"] == "allow" for r in acl["rules"])
    zenoh.Config().insert_json5("access_control", json.dumps(acl))  # Zenoh takes it as it is


def test_owners_are_the_agents_robots_and_any_for_a_bridge() -> None:
    assert owners(parse_policy(POLICY)) == {"alice": (1, 2), "legacy": None}


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ('[identities.a]\nrole = "pilot"', "identities.a.role"),
        ('[identities.a]\nrole = "world"\nrobots = [1]', "identities.a.robots"),
        (
            '[identities.a]\nrole = "agent"\nrobots = [1]\n[identities.b]\nrole = "agent"\nrobots = [1]',
            "identities.b.robots",
        ),
        ('[identities.a]\nrole = "sensors"\nshard = "3/2"', "identities.a.shard"),
        ('[identities."a/b"]\nrole = "world"', "policy"),
        ("[identities.a]\nrole = []", "identities.a.role"),
        ('[identities.a]\nrole = "agent"\nrobots = [1, 1]', "identities.a.robots"),
        (f'[identities.a]\nrole = "agent"\nrobots = [{2**64}]', "policy"),
    ],
)
def test_a_bad_policy_is_refused_naming_the_field(text: str, field: str) -> None:
    with pytest.raises(ConfigError) as e:
        parse_policy(text)
    assert field in e.value.field


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("[identities.a]\nrole = []", "no role; give one of world"),
        ('[identities.a]\nrole = "agent"\nrobots = [1, 1]', "robot 1 is listed twice"),
        ('[identities.a]\nrole = "sensors"\nshard = "x"', 'a shard is "K/N", e.g. "1/2"'),
        ('sim = "a b"', "a name (an identity's, or sim) is text without"),
    ],
)
def test_a_bad_policy_says_what_is_wrong_in_words(text: str, says: str) -> None:
    with pytest.raises(ConfigError) as e:
        parse_policy(text)
    assert says in e.value.reason
    assert "regex" not in e.value.reason


def test_a_bridge_publishes_actions_only_in_its_own_batch_and_the_serial_bridge_none() -> None:
    bridge, serial = _puts(("bridge",), name="legacy"), _puts(("serial",), name="chair")
    assert {k for k in bridge if k.endswith("/actions")} == {"iw/s/agent/legacy/actions"}
    assert not {k for k in serial if k.endswith("/actions")}
    assert not {k for k in serial if "*" in k and ("pose_report" in k or "chair" in k)}  # no robot's but its chair's
    assert {"iw/s/robot/4/pose_report", "iw/s/robot/4/chair"} <= _puts(("serial",), name="chair", robots=(4,))
    assert grants(("serial",), "s", name="chair").query == ("iw/s/world/info", "iw/s/world/register/chair")
    text = '[identities.chair]\nrole = "serial"\nrobots = [4]\n[identities.alice]\nrole = "agent"\nrobots = [4]'
    assert owners(parse_policy(text)) == {"chair": (4,), "alice": (4,)}  # the chair's agent drives it


def test_a_viewers_pages_drive_only_the_chairs_its_policy_entry_grants() -> None:
    for role in ("viewer", "operator"):
        drives = {k for k in _puts((role,), robots=(2, 5)) if k.endswith("/drive")}
        assert drives == {"iw/s/robot/2/drive", "iw/s/robot/5/drive"}
        assert not {k for k in _puts((role,)) if k.endswith("/drive")}  # no robots: it drives none
    for role in POLICY_ROLES:  # nobody else publishes a driver's input (an agent: its own chairs' trace)
        if role not in ("viewer", "operator", "agent"):
            assert not {k for k in _puts((role,), robots=(2,)) if k.endswith("/drive")}, role
    p = parse_policy('[identities.seat]\nrole = "viewer"\nrobots = [2]\n[identities.a]\nrole = "agent"\nrobots = [2]')
    assert p.identities["seat"].robots == [2]  # a chair an agent drives and a viewer's pages may drive
