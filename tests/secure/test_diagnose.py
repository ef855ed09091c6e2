"""Why a secured process is refused, told from its own files: its certificate (expired, not yet
valid, of another authority) and the policy beside it (not named, no operator)."""

from __future__ import annotations

import datetime
import shutil
from pathlib import Path

from iw_zenoh.secure.certs import init_ca, issue
from iw_zenoh.secure.cli import add_identity
from iw_zenoh.secure.diagnose import control_denied, join_refused

NOW = datetime.datetime.now(datetime.UTC)


def _lab(tmp: Path) -> Path:
    ids = tmp / "ids"
    init_ca(ids)
    issue(ids, "boss")
    add_identity(ids / "policy.toml", "boss", ["operator"])
    issue(ids, "alice")
    add_identity(ids / "policy.toml", "alice", ["agent"], robots=[1])
    issue(ids, "both")
    add_identity(ids / "policy.toml", "both", ["bridge", "operator"])
    issue(ids, "stranger")
    return ids


def test_the_policy_beside_an_identity_tells_who_may_send_control(tmp_path: Path) -> None:
    ids = _lab(tmp_path)
    assert control_denied(str(ids / "boss")) == ""
    assert control_denied(str(ids / "both")) == ""
    assert control_denied(str(ids / "boss.crt")) == ""
    alice = control_denied(str(ids / "alice"))
    assert "'alice' may not send control" in alice
    assert "the role agent" in alice
    assert "'stranger' is not in the policy" in control_denied(str(ids / "stranger"))
    bare = tmp_path / "bare"  # no policy at hand: nothing can be told
    bare.mkdir()
    shutil.copy2(ids / "alice.crt", bare / "alice.crt")
    assert control_denied(str(bare / "alice")) == ""
    (ids / "policy.toml").write_text("not [ toml")  # unreadable: nothing told, the router decides
    assert control_denied(str(ids / "alice")) == ""


def test_an_expired_not_yet_valid_or_foreign_certificate_is_named_before_any_dial(tmp_path: Path) -> None:
    ids = _lab(tmp_path)
    later = NOW + datetime.timedelta(days=3650)
    assert "expired on" in join_refused(str(ids / "boss"), [], now=later)
    earlier = NOW - datetime.timedelta(days=1)
    assert "is not valid before" in join_refused(str(ids / "boss"), [], now=earlier)
    other = tmp_path / "other"
    init_ca(other)
    shutil.copy2(other / "ca.crt", ids / "ca.crt")  # another authority's ca.crt beside the certificate
    assert "was not issued by the authority beside it" in join_refused(str(ids / "boss"), [])
    assert "does not exist" in join_refused(str(tmp_path / "nobody"), [])


def test_nothing_listening_is_said_and_a_plain_endpoint_is_not_dialled(tmp_path: Path) -> None:
    from iw_zenoh.bus.net import free_port

    ids = _lab(tmp_path)
    assert "nothing answers at 127.0.0.1" in join_refused(str(ids / "boss"), [f"tls/127.0.0.1:{free_port()}"])
    assert join_refused(str(ids / "boss"), ["tcp/127.0.0.1:1", "tls/no-port"]) == ""


def test_a_key_that_does_not_match_its_certificate_is_said_not_raised(tmp_path: Path) -> None:
    from iw_zenoh.bus.net import free_port

    ids = _lab(tmp_path)
    shutil.copy2(ids / "alice.key", ids / "boss.key")  # an old key beside a certificate issued again
    why = join_refused(str(ids / "boss"), [f"tls/127.0.0.1:{free_port()}"])
    assert "does not match the certificate" in why
    assert str(ids / "boss.key") in why
    (ids / "boss.key").write_text("")  # unreadable as a key
    assert "does not match the certificate" in join_refused(str(ids / "boss"), [f"tls/127.0.0.1:{free_port()}"])
