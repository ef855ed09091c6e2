"""Errors that name the cause, with real certificates on a secured router (issue 33): ``iwz ctl``
with an agent's identity says the identity may not send control (not "no answer from the world"),
and a refused certificate says which and why (expired, another authority, not in the policy), not
"cannot join the bus ... Is iwz router running there?"."""

from __future__ import annotations

import datetime
import shutil
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization

from iw_zenoh.bus.net import free_port
from iw_zenoh.secure.certs import init_ca, issue
from iw_zenoh.secure.cli import add_identity
from tests.integration.harness import Net

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

LAB = '<Lab Name="open" Width="20" Height="10"/>'
QUICK = ["--cfg", "connect/timeout_ms:{client: 3000}"]  # a refused connection is known in seconds


@dataclass
class Run:
    net: Net
    ids: Path
    endpoint: str


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Run]:
    """A secured router (its policy) and world; identities of an operator, an agent, a stranger."""
    tmp = tmp_path_factory.mktemp("secerr")
    ids = tmp / "ids"
    init_ca(ids)
    issue(ids, "router", server=True)
    for name, roles in (("world", ["world"]), ("boss", ["operator"]), ("alice", ["agent"])):
        issue(ids, name)
        add_identity(ids / "policy.toml", name, roles, robots=[1] if roles == ["agent"] else ())
    issue(ids, "stranger")  # of the authority, not in the policy
    (ids / "policy.toml").write_text((ids / "policy.toml").read_text().replace('sim = "default"', 'sim = "err"'))
    (tmp / "lab.xml").write_text(LAB)
    net = Net(tmp, sim="err")
    try:
        net.start_secured_router(ids)
        endpoint = net.endpoint
        net.launch(
            "world",
            [sys.executable, "-m", "iw_zenoh.cli", "world", str(tmp / "lab.xml"), "--policy", str(ids / "policy.toml")]
            + ["--sim", "err", "--name", "world", "--identity", str(ids / "world"), "-e", endpoint],
        )
        yield Run(net, ids, endpoint)
    finally:
        net.close()


def _ctl(run: Run, identity: Path, *words: str, timeout_s: str = "20") -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "-m", "iw_zenoh.cli", "ctl", *words, "--sim", "err", "--timeout", timeout_s]
    argv += ["--identity", str(identity), "-e", run.endpoint, *QUICK]
    return subprocess.run(argv, capture_output=True, text=True, timeout=120)


def test_ctl_with_an_agents_identity_says_it_may_not_send_control(run: Run) -> None:
    r = _ctl(run, run.ids / "alice", "pause")
    out = r.stdout + r.stderr
    assert r.returncode == 4, out
    assert "'alice' may not send control" in out
    assert "the role agent, and only an operator may" in out
    assert "no answer from the world" not in out
    ok = _ctl(run, run.ids / "boss", "pause")  # an operator's pause is obeyed: the world answers it
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert "paused" in ok.stdout


def test_ctl_with_an_identity_not_in_the_policy_says_so(run: Run) -> None:
    r = _ctl(run, run.ids / "stranger", "pause")
    out = r.stdout + r.stderr
    assert r.returncode == 4, out
    assert "'stranger' is not in the policy" in out


def test_ctl_without_the_policy_at_hand_says_the_router_may_have_dropped_it(run: Run, tmp_path: Path) -> None:
    copy = tmp_path / "ids"  # an agent's files copied to another laptop, without the policy
    copy.mkdir()
    for f in ("ca.crt", "alice.crt", "alice.key"):
        shutil.copy2(run.ids / f, copy / f)
    # as long as it takes the world to describe itself on a loaded machine; the control then goes unanswered
    r = _ctl(run, copy / "alice", "pause", timeout_s="10")
    out = r.stdout + r.stderr
    assert r.returncode == 3, out
    assert "drops a control from an identity that is no operator" in out


def _expired(ids: Path, name: str, into: Path) -> Path:
    """A copy of identity ``name`` (key kept) whose certificate expired yesterday, signed by the lab's authority."""
    into.mkdir(exist_ok=True)
    shutil.copy2(ids / "ca.crt", into / "ca.crt")
    shutil.copy2(ids / f"{name}.key", into / f"{name}.key")
    cert = x509.load_pem_x509_certificate((ids / f"{name}.crt").read_bytes())
    ca_key = serialization.load_pem_private_key((ids / "ca.key").read_bytes(), password=None)
    now = datetime.datetime.now(datetime.UTC)
    b = (
        x509.CertificateBuilder()
        .subject_name(cert.subject)
        .issuer_name(cert.issuer)
        .public_key(cert.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(days=30))
        .not_valid_after(now - datetime.timedelta(days=1))
    )
    for ext in cert.extensions:
        b = b.add_extension(ext.value, critical=ext.critical)
    signed = b.sign(ca_key, hashes.SHA256())  # type: ignore[arg-type]
    (into / f"{name}.crt").write_bytes(signed.public_bytes(serialization.Encoding.PEM))
    return into / name


def test_a_refused_certificate_says_which_and_why(run: Run, tmp_path: Path) -> None:
    other = tmp_path / "other"  # another lab's authority
    init_ca(other)
    issue(other, "alien")
    r = _ctl(run, other / "alien", "pause")
    out = r.stdout + r.stderr
    assert r.returncode == 2, out
    assert f"as the identity {other / 'alien'}" in out, out
    assert "not of the authority" in out, out
    assert "Is `iwz router` running there" not in out

    expired = _expired(run.ids, "boss", tmp_path / "expired")
    r = _ctl(run, expired, "pause")
    out = r.stdout + r.stderr
    assert r.returncode == 2, out
    assert f"the certificate {expired}.crt expired on" in out, out

    mixed = tmp_path / "mixed"  # another authority's certificate, trusting both: the router refuses it
    shutil.copytree(other, mixed)
    (mixed / "ca.crt").write_bytes((other / "ca.crt").read_bytes() + (run.ids / "ca.crt").read_bytes())
    r = _ctl(run, mixed / "alien", "pause")
    out = r.stdout + r.stderr
    assert r.returncode == 2, out
    assert f"refused the certificate {mixed / 'alien'}.crt" in out, out


def test_a_router_not_running_is_still_said_so(run: Run, tmp_path: Path) -> None:
    argv = [sys.executable, "-m", "iw_zenoh.cli", "ctl", "pause", "--sim", "err", "--timeout", "5"]
    argv += ["--identity", str(run.ids / "boss"), "-e", f"tls/127.0.0.1:{free_port()}", *QUICK]
    r = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    out = r.stdout + r.stderr
    assert r.returncode == 2, out
    assert "nothing answers at 127.0.0.1" in out or "Is `iwz router` running there" in out
