from __future__ import annotations

import json
from pathlib import Path

import pytest
import zenoh

from iw_zenoh.secure.cli import main
from iw_zenoh.secure.policy import load_policy


def test_init_issue_and_config_make_a_policy_and_the_routers_configuration(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ids = tmp_path / "ids"
    assert main(["init", str(ids), "--sim", "lab"]) == 0
    assert main(["issue", "router", "--role", "router", "--dir", str(ids), "--host", "10.0.0.1"]) == 0
    assert main(["issue", "alice", "--role", "agent", "--robots", "1,2", "--dir", str(ids)]) == 0
    assert main(["issue", "s1", "--role", "sensors", "--shard", "1/2", "--dir", str(ids)]) == 0
    policy = load_policy(ids / "policy.toml")
    assert policy.sim == "lab"
    assert set(policy.identities) == {"alice", "s1"}  # the router plays no role of the policy
    assert policy.identities["alice"].robots == [1, 2]
    out = tmp_path / "router.json5"
    assert main(["config", str(ids / "policy.toml"), "--identity", str(ids / "router"), "-o", str(out)]) == 0
    conf = zenoh.Config.from_file(str(out))
    assert json.loads(conf.get_json("listen/endpoints")) == ["tls/127.0.0.1:7447"]
    assert json.loads(conf.get_json("access_control/default_permission")) == "deny"
    capsys.readouterr()


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["issue", "bob", "--role", "agent", "--robots", "x"], "--robots takes robot ids"),
        (["issue", "bob", "--role", "world", "--robots", "1"], "only an agent drives robots"),
        (["init", "{ids}"], "an authority is here already"),
    ],
)
def test_a_refused_command_says_what_and_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], said: str
) -> None:
    main(["init", str(tmp_path)])
    argv = [a.replace("{ids}", str(tmp_path)) for a in argv]
    if argv[0] == "issue":
        argv += ["--dir", str(tmp_path)]
    capsys.readouterr()
    assert main(argv) == 2
    assert said in capsys.readouterr().out
    assert not (tmp_path / "bob.crt").exists()  # nothing is made for a refused identity


@pytest.mark.parametrize(
    "again",
    [
        ["--role", "agent", "--robots", "3"],
        ["--role", "operator"],
        ["--role", "sensors", "--shard", "1/2"],
    ],
)
def test_issuing_a_name_again_otherwise_is_refused_before_its_certificate_is_replaced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], again: list[str]
) -> None:
    main(["init", str(tmp_path)])
    assert main(["issue", "alice", "--role", "agent", "--robots", "1,2", "--dir", str(tmp_path)]) == 0
    cert = (tmp_path / "alice.crt").read_bytes()
    capsys.readouterr()
    assert main(["issue", "alice", *again, "--dir", str(tmp_path)]) == 2
    out = capsys.readouterr().out
    assert "identities.alice: 'alice' is there already (role ['agent'], robots [1, 2], shard '')" in out
    assert "edit or remove its table in the policy first" in out
    assert (tmp_path / "alice.crt").read_bytes() == cert
    assert load_policy(tmp_path / "policy.toml").identities["alice"].robots == [1, 2]
    assert main(["issue", "alice", "--role", "agent", "--robots", "1,2", "--dir", str(tmp_path)]) == 0  # as it is


@pytest.mark.parametrize(
    ("name", "said"),
    [("a b", "a name (an identity's, or sim) is text without /, *, $, ?, # or spaces")],
)
def test_a_refused_name_says_what_a_name_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, said: str
) -> None:
    main(["init", str(tmp_path)])
    capsys.readouterr()
    assert main(["issue", name, "--role", "world", "--dir", str(tmp_path)]) == 2
    out = capsys.readouterr().out
    assert said in out
    assert "regex" not in out
