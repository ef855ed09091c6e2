"""How a --zenoh-config file, the flags and the built-in defaults combine (issue 20)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from iw_zenoh.bus.net import NetConfig, build_config
from iw_zenoh.errors import ConfigError
from iw_zenoh.secure.certs import init_ca, issue


def _get(conf: object, key: str) -> object:
    return json.loads(conf.get_json(key))  # type: ignore[attr-defined]


def _file(tmp_path: Path, text: str) -> str:
    p = tmp_path / "z.json5"
    p.write_text(text)
    return str(p)


def test_a_routers_file_keeps_its_listen_endpoint(tmp_path: Path) -> None:
    f = _file(tmp_path, '{ listen: { endpoints: ["tcp/127.0.0.1:17001"] }, // the file says where\n}')
    conf, notes = build_config(NetConfig(mode="router", config_file=f))
    assert _get(conf, "listen/endpoints") == ["tcp/127.0.0.1:17001"]
    assert notes == []


def test_a_flag_replaces_the_files_value_and_says_so(tmp_path: Path) -> None:
    f = _file(tmp_path, '{ listen: { endpoints: ["tcp/127.0.0.1:17001"] } }')
    conf, notes = build_config(NetConfig(mode="router", listen=("tcp/127.0.0.1:17002",), config_file=f))
    assert _get(conf, "listen/endpoints") == ["tcp/127.0.0.1:17002"]
    assert len(notes) == 1
    assert "listen/endpoints" in notes[0]
    assert "--listen" in notes[0]


def test_the_files_values_stand_where_only_a_default_would_replace_them(tmp_path: Path) -> None:
    f = _file(
        tmp_path, "{ transport: { link: { tx: { lease: 9000 } } }, connect: { endpoints: ['tcp/10.1.1.1:7447'] } }"
    )
    conf, notes = build_config(NetConfig(config_file=f))
    assert _get(conf, "transport/link/tx/lease") == 9000
    assert _get(conf, "connect/endpoints") == ["tcp/10.1.1.1:7447"]
    assert notes == []


def test_a_cfg_override_of_a_files_value_is_reported(tmp_path: Path) -> None:
    f = _file(tmp_path, "{ transport: { link: { tx: { lease: 9000 } } } }")
    conf, notes = build_config(NetConfig(config_file=f, overrides=("transport/link/tx/lease:4000",)))
    assert _get(conf, "transport/link/tx/lease") == 4000
    assert notes == [f"{f}: transport/link/tx/lease is overridden by --cfg transport/link/tx/lease:4000"]


def test_a_secured_client_speaks_tls_only_to_the_router_with_its_certificate(tmp_path: Path) -> None:
    init_ca(tmp_path)
    issue(tmp_path, "alice")
    conf, _ = build_config(NetConfig(identity=str(tmp_path / "alice")))
    assert _get(conf, "connect/endpoints") == ["tls/127.0.0.1:7447"]
    assert _get(conf, "transport/link/protocols") == ["tls"]
    assert _get(conf, "transport/link/tls/connect_certificate") == str(tmp_path / "alice.crt")
    assert _get(conf, "scouting/multicast/enabled") is False


def test_a_files_scouting_is_turned_off_for_a_secured_process_and_reported(tmp_path: Path) -> None:
    init_ca(tmp_path)
    issue(tmp_path, "alice")
    f = _file(tmp_path, "{ scouting: { multicast: { enabled: true } } }")
    conf, notes = build_config(NetConfig(identity=str(tmp_path / "alice"), config_file=f))
    assert _get(conf, "scouting/multicast/enabled") is False
    assert any("scouting/multicast/enabled" in n and "--identity" in n for n in notes)


@pytest.mark.parametrize(
    ("net", "flag"),
    [
        (NetConfig(mode="peer"), "--identity"),
        (NetConfig(lan=True), "--identity"),
        (NetConfig(listen=("tls/127.0.0.1:7000",)), "--listen"),
        (NetConfig(policy="p.toml"), "--policy"),
    ],
)
def test_a_secured_process_cannot_go_around_the_router(tmp_path: Path, net: NetConfig, flag: str) -> None:
    init_ca(tmp_path)
    issue(tmp_path, "alice")
    with pytest.raises(ConfigError) as e:
        build_config(NetConfig(**{**net.__dict__, "identity": str(tmp_path / "alice")}))
    assert e.value.field == flag


def test_an_agents_own_policy_option_is_not_the_routers_security_policy() -> None:
    # the door agent's --policy negotiate once reached the network configuration and ended the
    # agent with "only the router enforces a policy": every door scenario failed to start
    import argparse

    from iw_zenoh.process.cliargs import add_common_arguments, net_from_args

    door = argparse.ArgumentParser()
    add_common_arguments(door)
    door.add_argument("--policy", choices=["automatic", "negotiate"], default="automatic")
    args = door.parse_args(["--policy", "negotiate"])
    assert net_from_args(args).policy is None
    build_config(net_from_args(args))  # and the agent's network configuration builds


@pytest.mark.parametrize(
    ("net", "flag"),
    [(NetConfig(connect=("garbage",)), "--connect"), (NetConfig(mode="router", listen=("tcp",)), "--listen")],
)
def test_an_endpoint_zenoh_refuses_is_a_config_error_naming_the_flag(net: NetConfig, flag: str) -> None:
    with pytest.raises(ConfigError) as e:
        build_config(net)
    assert e.value.field == flag
    assert "PROTOCOL/ADDRESS:PORT" in e.value.reason
