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
    assert said in capsys.readouterr().err
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
    out = capsys.readouterr().err
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
    out = capsys.readouterr().err
    assert said in out
    assert "regex" not in out


def _garble(path: Path) -> None:
    path.write_text("not PEM\n")


@pytest.mark.parametrize(
    ("setup", "argv", "what", "fix"),
    [
        (None, ["issue", "w", "--role", "world", "--dir", "{t}/nowhere"], "{t}/nowhere: does not exist", "init"),
        ("file", ["issue", "w", "--role", "world", "--dir", "{t}/afile"], "{t}/afile: is not a folder", "--dir"),
        ("empty", ["issue", "w", "--role", "world", "--dir", "{t}/ids"], "{t}/ids: no authority here", "init {t}/ids"),
        (
            "ca.crt",
            ["issue", "w", "--role", "world", "--dir", "{t}/ids"],
            "{t}/ids/ca.crt: not a certificate",
            "--force",
        ),
        ("ca.key", ["issue", "w", "--role", "world", "--dir", "{t}/ids"], "{t}/ids/ca.key: not a key", "restore it"),
        ("no-key", ["issue", "w", "--role", "world", "--dir", "{t}/ids"], "{t}/ids/ca.key: missing", "issue there"),
        ("toml", ["issue", "w", "--role", "world", "--dir", "{t}/ids"], "policy.toml: not valid TOML", "fix the file"),
        ("role", ["issue", "w", "--role", "world", "--dir", "{t}/ids"], "identities.a.role: unknown role", "one of"),
        (
            None,
            ["config", "{t}/none.toml", "--identity", "{t}/ids/router"],
            "cannot read the policy",
            "iwz secure init",
        ),
        ("ok", ["config", "{t}/ids/policy.toml", "--identity", "{t}/ids/nobody"], "nobody.crt does not exist", "issue"),
        (
            "router",
            ["config", "{t}/ids/policy.toml", "--identity", "{t}/ids/router", "-o", "{t}/no/r.json5"],
            "cannot write",
            "a folder you may write",
        ),
        ("file", ["init", "{t}/afile/ids"], "{t}/afile/ids: cannot make this folder", "another DIR"),
        (
            "dir-key",
            ["issue", "w", "--role", "world", "--dir", "{t}/ids"],
            "{t}/ids/w.key: cannot write it",
            "may write",
        ),
    ],
)
def test_every_refusal_goes_to_stderr_saying_what_and_how_to_fix_it_and_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], setup: str | None, argv: list[str], what: str, fix: str
) -> None:
    ids = tmp_path / "ids"
    if setup == "file":
        (tmp_path / "afile").write_text("")
    elif setup == "empty":
        ids.mkdir()
    elif setup is not None:
        main(["init", str(ids)])
    if setup == "router":
        main(["issue", "router", "--role", "router", "--dir", str(ids)])
    changes = {
        "ca.crt": lambda: _garble(ids / "ca.crt"),
        "ca.key": lambda: _garble(ids / "ca.key"),
        "no-key": lambda: (ids / "ca.key").unlink(),
        "toml": lambda: (ids / "policy.toml").write_text("sim = \n"),
        "role": lambda: (ids / "policy.toml").write_text('sim = "s"\n[identities.a]\nrole = "pilot"\n'),
        "dir-key": lambda: (ids / "w.key").mkdir(),
    }
    if setup in changes:
        changes[setup]()
    capsys.readouterr()
    assert main([a.replace("{t}", str(tmp_path)) for a in argv]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # nothing a script would take for a result
    assert err.startswith("iwz secure: "), err
    assert what.replace("{t}", str(tmp_path)) in err, err
    how = err.partition("; ")[2]
    assert fix.replace("{t}", str(tmp_path)) in how, err  # what; how to fix
    assert "Traceback" not in err
    assert not (ids / "w.crt").exists()  # nothing is issued by a refused command
