from __future__ import annotations

import ipaddress
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.x509.oid import ExtendedKeyUsageOID

from iw_zenoh.errors import ConfigError
from iw_zenoh.secure.certs import identity_files, init_ca, issue, read_common_name


def _cert(path: Path) -> x509.Certificate:
    return x509.load_pem_x509_certificate(path.read_bytes())


def test_an_identity_is_signed_by_the_authority_and_named_by_its_common_name(tmp_path: Path) -> None:
    init_ca(tmp_path)
    ident = issue(tmp_path, "alice", hosts=("lab-pc", "10.0.0.5"))
    cert, ca = _cert(ident.cert), _cert(ident.ca)
    cert.verify_directly_issued_by(ca)
    assert read_common_name(ident.cert) == "alice"
    san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert set(san.get_values_for_type(x509.DNSName)) == {"localhost", "lab-pc"}
    assert set(san.get_values_for_type(x509.IPAddress)) == {
        ipaddress.ip_address("127.0.0.1"),
        ipaddress.ip_address("10.0.0.5"),
    }
    assert (ident.key.stat().st_mode & 0o777) == 0o600


def test_only_the_router_may_serve_tls(tmp_path: Path) -> None:
    init_ca(tmp_path)
    usage = {
        n: set(
            _cert(issue(tmp_path, n, server=n == "router").cert)
            .extensions.get_extension_for_class(x509.ExtendedKeyUsage)
            .value
        )
        for n in ("router", "alice")
    }
    assert ExtendedKeyUsageOID.SERVER_AUTH in usage["router"]
    assert usage["alice"] == {ExtendedKeyUsageOID.CLIENT_AUTH}


def test_an_authority_is_not_replaced_unless_forced(tmp_path: Path) -> None:
    init_ca(tmp_path)
    with pytest.raises(ConfigError, match="--force"):
        init_ca(tmp_path)
    init_ca(tmp_path, force=True)


def test_issuing_without_an_authority_says_how_to_make_one(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="iwz secure init"):
        issue(tmp_path, "alice")


def test_a_name_that_is_no_key_chunk_is_refused(tmp_path: Path) -> None:
    init_ca(tmp_path)
    with pytest.raises(ConfigError, match="key chunk"):
        issue(tmp_path, "a/b")


def test_a_missing_identity_file_is_named_with_how_to_make_it(tmp_path: Path) -> None:
    init_ca(tmp_path)
    with pytest.raises(ConfigError, match="iwz secure issue bob"):
        identity_files(tmp_path / "bob")
    issue(tmp_path, "bob")
    assert identity_files(tmp_path / "bob.crt").key == tmp_path / "bob.key"
