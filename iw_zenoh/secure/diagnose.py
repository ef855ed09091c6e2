"""Why a secured process could not join, or may not do what it asks: the cause named, with the
certificate or the policy entry it comes from (Zenoh itself only says "Timeout!").

:func:`join_refused` looks at the identity's own certificate (expired, not yet valid, not issued by
the ``ca.crt`` beside it), then dials the router's TLS endpoint once as that identity and reads its
answer: the router's certificate refused here (another authority, another host name), or ours
refused there (its TLS alert: unknown authority, expired, bad certificate). :func:`control_denied`
reads the policy beside the identity (``DIR/policy.toml``, where ``iwz secure issue`` writes it):
whether it names the identity, and as an operator (only an operator publishes on
``world/control``).
"""

from __future__ import annotations

import datetime
import socket
import ssl
from pathlib import Path

from cryptography import x509
from cryptography.exceptions import InvalidSignature

from iw_zenoh.errors import ConfigError
from iw_zenoh.secure.certs import identity_files
from iw_zenoh.secure.policy import load_policy

__all__ = ["POLICY_FILE", "control_denied", "join_refused"]

POLICY_FILE = "policy.toml"  # beside the identities, as iwz secure issue writes it
PROBE_S = 3.0  # the one dial of the router, and the wait for its verdict on our certificate
ALERTS = {  # OpenSSL's name of the router's TLS alert: what it means here
    "UNKNOWN_CA": "unknown authority: the router trusts another ca.crt (was it issued by another `iwz secure init`?)",
    "CERTIFICATE_EXPIRED": "expired, as the router's clock reads it",
    "BAD_CERTIFICATE": "a bad certificate (not one of a client, or damaged)",
    "CERTIFICATE_UNKNOWN": "not accepted (not of its authority, or not a client's)",
    "UNSUPPORTED_CERTIFICATE": "not a client's certificate (its key usage)",
    "CERTIFICATE_REVOKED": "revoked",
    "CERTIFICATE_REQUIRED": "missing",
    "DECRYPT_ERROR": "not signed by the key it names",
}


def _own(cert_path: Path, ca_path: Path, now: datetime.datetime) -> str:
    """What is wrong with the identity's certificate on its own ("" when nothing)."""
    cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
    ca = x509.load_pem_x509_certificate(ca_path.read_bytes())
    name = cert_path.stem
    again = f"issue it again: `iwz secure issue {name} --role ROLE --dir {cert_path.parent}`"
    if cert.not_valid_after_utc < now:
        return f"the certificate {cert_path} expired on {cert.not_valid_after_utc:%Y-%m-%d %H:%M} UTC; {again}"
    if cert.not_valid_before_utc > now:
        since = f"{cert.not_valid_before_utc:%Y-%m-%d %H:%M}"
        return f"the certificate {cert_path} is not valid before {since} UTC (is this machine's clock right?)"
    try:
        cert.verify_directly_issued_by(ca)
    except (InvalidSignature, ValueError, TypeError):  # another key's signature, another issuer's name
        return (
            f"the certificate {cert_path} was not issued by the authority beside it ({ca_path}): "
            f"a certificate and its ca.crt come from the same `iwz secure init` folder; {again}"
        )
    return ""


def _host_port(endpoint: str) -> tuple[str, int] | None:
    proto, _, addr = endpoint.partition("/")
    if proto != "tls" or ":" not in addr:
        return None
    host, _, port = addr.split("#")[0].rpartition(":")
    try:
        return host.strip("[]"), int(port)
    except ValueError:
        return None


def _probe(cert_path: Path, key_path: Path, ca_path: Path, endpoint: str) -> str:
    """Dials ``endpoint`` once over TLS as the identity: why it is refused ("" when it is not, or
    nothing can be told)."""
    where = _host_port(endpoint)
    if where is None:
        return ""
    host, port = where
    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    try:
        ctx.load_verify_locations(cafile=str(ca_path))
    except (ssl.SSLError, OSError) as e:
        return f"cannot read the authority's certificate {ca_path}: {e}"
    try:
        ctx.load_cert_chain(str(cert_path), str(key_path))
    except ssl.SSLError as e:
        return (
            f"the key {key_path} does not match the certificate {cert_path} ({e.reason or e}): an old key "
            f"beside a certificate issued again? issue both again: `iwz secure issue {cert_path.stem} --role ROLE "
            f"--dir {cert_path.parent}`"
        )
    except OSError as e:
        return f"cannot read the key {key_path}: {e.strerror or e}"
    try:
        raw = socket.create_connection((host, port), timeout=PROBE_S)
    except OSError as e:
        return f"nothing answers at {host}:{port} ({e.strerror or e}): is `iwz router` running there?"
    try:
        with ctx.wrap_socket(raw, server_hostname=host) as tls:
            tls.settimeout(PROBE_S)
            try:
                tls.recv(1)  # TLS 1.3: the router's verdict on our certificate comes after the handshake
            except TimeoutError:
                return ""  # accepted: it waits for Zenoh's first message
            return ""
    except ssl.SSLCertVerificationError as e:
        return f"this process refuses the router's certificate at {host}:{port} ({e.verify_message}): " + (
            f"it does not name {host}; issue the router's with `--host {host}`"
            if "mismatch" in (e.verify_message or "")
            else f"it is not of the authority {ca_path}: the identity and the router come from different "
            "`iwz secure init` folders"
        )
    except ssl.SSLError as e:
        reason = str(e.reason or "")
        for alert, means in ALERTS.items():
            if reason.endswith(alert):
                return f"the router at {host}:{port} refused the certificate {cert_path}: {means}"
        return f"the TLS handshake with {host}:{port} failed ({reason or e})"
    except OSError:
        return ""  # closed or reset: nothing more can be told from here
    finally:
        raw.close()


def join_refused(identity: str, endpoints: list[str], now: datetime.datetime | None = None) -> str:
    """Why the identity ``DIR/NAME`` could not join the router at ``endpoints`` ("" when no cause
    is found: then the router may be down, or the network)."""
    try:
        ident = identity_files(identity)
    except ConfigError as e:
        return str(e)
    try:
        own = _own(ident.cert, ident.ca, now or datetime.datetime.now(datetime.UTC))
    except (OSError, ValueError) as e:
        return f"cannot read the certificate {ident.cert} or {ident.ca}: {e}"
    if own:
        return own
    for endpoint in endpoints:
        if why := _probe(ident.cert, ident.key, ident.ca, endpoint):
            return why
    return ""


def control_denied(identity: str) -> str:
    """Why the identity ``DIR/NAME`` may not send the world a control, by the policy beside it
    (``DIR/policy.toml``): "" when it may, or there is no policy there to tell."""
    p = Path(identity)
    name = p.stem if p.suffix == ".crt" else p.name
    policy_path = p.parent / POLICY_FILE
    if not policy_path.is_file():
        return ""
    try:
        policy = load_policy(policy_path)
    except ConfigError:
        return ""
    entry = policy.identities.get(name)
    if entry is None:
        return (
            f"the identity {name!r} is not in the policy {policy_path}: the router sends it nothing and refuses "
            f"everything it sends; add it (`iwz secure issue {name} --role operator --dir {p.parent}`) and "
            "restart the router"
        )
    if "operator" not in entry.roles:
        return (
            f"the identity {name!r} may not send control: {policy_path} gives it the role "
            f"{' and '.join(entry.roles)}, and only an operator may publish on world/control (the router drops "
            "it unseen); use an operator's identity (e.g. --identity DIR/operator; `iwz secure issue NAME "
            "--role operator`)"
        )
    return ""
