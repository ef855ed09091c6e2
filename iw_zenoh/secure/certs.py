"""A certificate authority and one certificate per process identity (``iwz secure init / issue``).

A folder of identities holds ``ca.crt`` (the authority every process trusts), ``ca.key`` (its
private key: only ``iwz secure issue`` needs it), and for each identity ``NAME.crt`` and
``NAME.key``. The common name (CN) of a certificate is its identity's name: the router's access
control finds each process's permissions by it. A certificate names ``localhost`` and
``127.0.0.1`` (and any host given) as where it may be reached. Only the router's certificate may
serve TLS (extended key usage ``serverAuth``): a process holding an agent's certificate cannot
pose as the router.
"""

from __future__ import annotations

import datetime
import ipaddress
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from iw_zenoh.errors import ConfigError

__all__ = ["CA_CERT", "CA_KEY", "Identity", "identity_files", "init_ca", "issue", "read_common_name"]

CA_CERT = "ca.crt"
CA_KEY = "ca.key"
CA_DAYS = 3650  # a lab's authority outlives its runs
CERT_DAYS = 825  # what browsers accept for a leaf certificate; a lab reissues rarely
_REISSUE = "every identity it issued is then refused: issue them again"
LOCAL_NAMES = ("localhost", "127.0.0.1")  # every identity may be reached on loopback


@dataclass(frozen=True)
class Identity:
    """Where one identity's files are.

    Attributes:
        cert: Its certificate (PEM).
        key: Its private key (PEM).
        ca: The authority's certificate (PEM).
    """

    cert: Path
    key: Path
    ca: Path


def identity_files(path: str | Path) -> Identity:
    """The files of the identity ``DIR/NAME`` (``DIR/NAME.crt``, ``DIR/NAME.key``, ``DIR/ca.crt``).

    Args:
        path: ``DIR/NAME`` (a trailing ``.crt`` is allowed).

    Raises:
        ConfigError: When one of the three files is missing, naming it and how to make it.
    """
    p = Path(path)
    if p.suffix == ".crt":
        p = p.with_suffix("")
    ident = Identity(cert=p.with_name(p.name + ".crt"), key=p.with_name(p.name + ".key"), ca=p.parent / CA_CERT)
    for f in (ident.ca, ident.cert, ident.key):
        if not f.is_file():
            raise ConfigError(
                "--identity",
                f"{f} does not exist; make it with `iwz secure init {p.parent}` and "
                f"`iwz secure issue {p.name} --role ROLE --dir {p.parent}`",
            )
    return ident


def _write(path: Path, data: bytes, *, secret: bool) -> None:
    path.write_bytes(data)
    if secret:
        path.chmod(0o600)


def _key_pem(key: ec.EllipticCurvePrivateKey) -> bytes:
    pem, pkcs8 = serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8
    return key.private_bytes(pem, pkcs8, serialization.NoEncryption())


def init_ca(folder: str | Path, *, name: str = "iw-zenoh lab CA", force: bool = False) -> Path:
    """Makes a certificate authority in ``folder`` (``ca.crt``, ``ca.key``).

    Args:
        folder: Where (made if missing).
        name: The authority's common name.
        force: Replace an authority already there (every identity it issued stops being trusted).

    Returns:
        The authority's certificate.

    Raises:
        ConfigError: When an authority is there already and ``force`` is not given.
    """
    d = Path(folder)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ConfigError(str(d), f"cannot make this folder ({e.strerror}); give another DIR") from None
    if (d / CA_CERT).exists() and not force:
        raise ConfigError(
            str(d / CA_CERT),
            "an authority is here already; --force replaces it (every identity it issued is then refused)",
        )
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)])
    now = datetime.datetime.now(datetime.UTC)
    cert = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=CA_DAYS))
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(
            x509.KeyUsage(
                digital_signature=True,
                content_commitment=False,
                key_encipherment=False,
                data_encipherment=False,
                key_agreement=False,
                key_cert_sign=True,
                crl_sign=True,
                encipher_only=False,
                decipher_only=False,
            ),
            critical=True,
        )
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
        .sign(key, hashes.SHA256())
    )
    _write(d / CA_KEY, _key_pem(key), secret=True)
    _write(d / CA_CERT, cert.public_bytes(serialization.Encoding.PEM), secret=False)
    return d / CA_CERT


def _san(hosts: tuple[str, ...]) -> x509.SubjectAlternativeName:
    names: list[x509.GeneralName] = []
    for h in dict.fromkeys((*LOCAL_NAMES, *hosts)):
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(h)))
        except ValueError:
            names.append(x509.DNSName(h))
    return x509.SubjectAlternativeName(names)


def _authority_file(d: Path, name: str) -> bytes:
    """One of the authority's files, or why it cannot be had and how to fix that."""
    f = d / name
    if not d.is_dir():
        there = "is not a folder" if d.exists() else "does not exist"
        raise ConfigError(str(d), f"{there}; give --dir the folder of ca.crt, or make one with `iwz secure init {d}`")
    if not f.exists() and name == CA_CERT:
        raise ConfigError(str(d), f"no authority here (no {CA_CERT}); make one with `iwz secure init {d}`")
    if not f.exists():
        raise ConfigError(
            str(f),
            "missing: identities are issued where the authority's key is (where `iwz secure init` ran); "
            f"issue there, or replace the authority with `iwz secure init {d} --force` ({_REISSUE})",
        )
    try:
        return f.read_bytes()
    except OSError as e:
        raise ConfigError(str(f), f"cannot read it ({e.strerror}); run as the user who made it") from None


def _load_ca(d: Path) -> tuple[x509.Certificate, ec.EllipticCurvePrivateKey]:
    cert, key_pem = _authority_file(d, CA_CERT), _authority_file(d, CA_KEY)
    broken = f"restore it from a copy, or replace the authority with `iwz secure init {d} --force` ({_REISSUE})"
    try:
        ca = x509.load_pem_x509_certificate(cert)
    except ValueError:
        raise ConfigError(str(d / CA_CERT), f"not a certificate made by `iwz secure init`; {broken}") from None
    try:
        key = serialization.load_pem_private_key(key_pem, password=None)
    except (ValueError, TypeError):
        raise ConfigError(str(d / CA_KEY), f"not a key made by `iwz secure init`; {broken}") from None
    if not isinstance(key, ec.EllipticCurvePrivateKey):
        raise ConfigError(str(d / CA_KEY), f"not an elliptic-curve key made by `iwz secure init`; {broken}")
    return ca, key


def issue(folder: str | Path, name: str, *, server: bool = False, hosts: tuple[str, ...] = ()) -> Identity:
    """Issues the identity ``name``: a key and a certificate signed by the authority in ``folder``.

    Args:
        folder: The authority's folder (``iwz secure init``); the identity's files go there.
        name: The identity (the certificate's common name; a key chunk: no ``/ * $ ? #``).
        server: May serve TLS (the router); every identity may be a TLS client.
        hosts: Host names or addresses it may be reached at, beside localhost and 127.0.0.1.

    Returns:
        Its files.

    Raises:
        ConfigError: No authority there, or a name that is not a valid identity.
    """
    from iw_zenoh.keys import chunk

    try:
        chunk(name)
    except ValueError as e:
        raise ConfigError("NAME", str(e)) from None
    d = Path(folder)
    ca, ca_key = _load_ca(d)
    key = ec.generate_private_key(ec.SECP256R1())
    now = datetime.datetime.now(datetime.UTC)
    usages = [ExtendedKeyUsageOID.CLIENT_AUTH, *([ExtendedKeyUsageOID.SERVER_AUTH] if server else [])]
    cert = (
        x509.CertificateBuilder()
        .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)]))
        .issuer_name(ca.subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=CERT_DAYS))
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(x509.ExtendedKeyUsage(usages), critical=False)
        .add_extension(_san(hosts), critical=False)
        .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()), critical=False)
        .sign(ca_key, hashes.SHA256())
    )
    ident = Identity(cert=d / f"{name}.crt", key=d / f"{name}.key", ca=d / CA_CERT)
    _write(ident.key, _key_pem(key), secret=True)
    _write(ident.cert, cert.public_bytes(serialization.Encoding.PEM), secret=False)
    return ident


def read_common_name(cert: str | Path) -> str:
    """The common name of a certificate file (its identity's name)."""
    c = x509.load_pem_x509_certificate(Path(cert).read_bytes())
    attrs = c.subject.get_attributes_for_oid(NameOID.COMMON_NAME)
    return str(attrs[0].value) if attrs else ""
