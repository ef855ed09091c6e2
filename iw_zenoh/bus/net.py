"""Zenoh configurations: the embedded loopback default, explicit endpoints, LAN scouting.

Default: a router on ``tcp/127.0.0.1:7447`` and every other process its client, multicast
scouting off, so nothing leaves the loopback interface unless the user asks. Secured
(``--identity``): mutual TLS only, clients of the router, the router enforcing a policy.
"""

from __future__ import annotations

import json
import logging
import socket
from dataclasses import dataclass, field
from typing import Any

import json5
import zenoh

from iw_zenoh.errors import ConfigError

__all__ = [
    "DEFAULT_ENDPOINT",
    "DEFAULT_PORT",
    "DEFAULT_TLS_ENDPOINT",
    "NetConfig",
    "build_config",
    "config_values",
    "free_port",
    "port_in_use",
    "tls_values",
    "zenoh_config",
]

logger = logging.getLogger(__name__)

DEFAULT_PORT = 7447
DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
DEFAULT_TLS_ENDPOINT = f"tls/127.0.0.1:{DEFAULT_PORT}"  # secured: the same router, TLS only
LEASE_MS = 3000  # a process whose link goes silent this long counts as lost
CONNECT_TIMEOUT_MS = 15000  # a client started before its router keeps trying this long
# a client whose router went away tries again this often (zenoh's default backs off to 4 s, so a
# router restarted by `iwz run` in half a second was found again only seconds later); zenoh
# re-declares every subscriber, queryable and liveliness token on the new link by itself
RETRY = {"period_init_ms": 100, "period_max_ms": 500, "period_increase_factor": 1.5}


@dataclass(frozen=True)
class NetConfig:
    """How one process joins the bus.

    Attributes:
        mode: ``client`` (default), ``peer`` or ``router``.
        connect: Endpoints to connect to (default: the local router).
        listen: Endpoints to listen on (routers; default ``tcp/127.0.0.1:7447``).
        lan: Turn multicast scouting on (several laptops without naming a router).
        config_file: A Zenoh JSON5 configuration file applied first.
        overrides: ``KEY:VALUE`` pairs (JSON5 values) applied last, as zenoh's ``--cfg``.
        identity: ``DIR/NAME``: join over mutual TLS as the identity NAME (``iwz secure``):
            TLS only, a client (or the router), no scouting, no listening but the router's.
        policy: A router's security policy (TOML): its access control, default deny.
    """

    mode: str = "client"
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    lan: bool = False
    config_file: str | None = None
    overrides: tuple[str, ...] = field(default_factory=tuple)
    identity: str | None = None
    policy: str | None = None

    @property
    def default_endpoint(self) -> str:
        """The router's endpoint when none is named: loopback, TLS when secured."""
        return DEFAULT_TLS_ENDPOINT if self.identity else DEFAULT_ENDPOINT


def zenoh_config(net: NetConfig) -> zenoh.Config:
    """Builds the Zenoh configuration of one process (see :func:`build_config`); every value of
    the file that is overridden is logged as a warning.

    Raises:
        ConfigError: For an unknown mode, an unreadable file or a malformed override.
    """
    conf, notes = build_config(net)
    for note in notes:
        logger.warning("%s", note)
    return conf


def build_config(net: NetConfig) -> tuple[zenoh.Config, list[str]]:
    """Builds the Zenoh configuration of one process, and says what of the file it overrides.

    The order, always the same: the file (``--zenoh-config``) first; then what the flags ask
    (``--mode``, ``--connect``, ``--listen``, ``--lan``, ``--identity``, ``--policy``), each
    replacing the file's value, which is reported; then the built-in defaults (loopback endpoint,
    no scouting, lease, reconnection) only where neither the file nor a flag says anything; then
    ``--cfg`` overrides, over everything (reported too when they replace a value).

    Returns:
        The configuration, and one line per value of the file that was replaced.

    Raises:
        ConfigError: For an unknown mode, an unreadable file, a malformed override, a peer or
            LAN scouting asked of a secured process, or a policy without an identity.
    """
    if net.mode not in ("client", "peer", "router"):
        raise ConfigError("--mode", f"must be client, peer or router, got {net.mode!r}")
    conf, doc = _load_file(net.config_file)
    notes: list[str] = []

    def put(key: str, value: object, *, given: bool, why: str) -> None:
        """Sets ``key``: a flag's value always (reporting the file's), a default only where the file is silent."""
        had = _lookup(doc, key)
        if had is not _MISSING and not given:
            return
        if had is not _MISSING and had != value:
            notes.append(f"{net.config_file}: {key} = {json.dumps(had)} is overridden by {why}: {json.dumps(value)}")
        try:
            conf.insert_json5(key, json.dumps(value))
        except Exception:  # zenoh.ZError, whose text is a Rust debug dump with a source path
            form = "; an endpoint is PROTOCOL/ADDRESS:PORT, e.g. tcp/127.0.0.1:7447" if "endpoints" in key else ""
            raise ConfigError(why, f"Zenoh refuses {json.dumps(value)} for {key}{form}") from None

    put("mode", net.mode, given=True, why="the role's mode (--mode)")
    for key, value, given, why in _flag_values(net):
        put(key, value, given=given, why=why)
    for item in net.overrides:
        key, sep, value = item.partition(":")
        if not sep or not key:
            raise ConfigError("--cfg", f"expects KEY:VALUE, got {item!r}")
        try:
            conf.insert_json5(key, value)
        except Exception as e:
            raise ConfigError("--cfg", f"{key}: {e}") from None
        if _lookup(doc, key) is not _MISSING:
            notes.append(f"{net.config_file}: {key} is overridden by --cfg {item}")
    return conf, notes


def config_values(net: NetConfig) -> dict[str, Any]:
    """What the flags and built-in defaults set, as a nested Zenoh configuration (a file for
    ``--zenoh-config``: ``iwz secure config`` writes the router's).

    Raises:
        ConfigError: As :func:`build_config`.
    """
    out: dict[str, Any] = {}
    values: list[tuple[str, object]] = [("mode", net.mode), *((k, v) for k, v, _, _ in _flag_values(net))]
    for key, value in values:
        *path, last = key.split("/")
        node = out
        for part in path:
            node = node.setdefault(part, {})
        node[last] = value
    return out


def _flag_values(net: NetConfig) -> list[tuple[str, object, bool, str]]:
    """``(key, value, given by a flag, which flag)`` for every value the flags or defaults set."""
    secure = net.identity is not None
    if secure and (net.mode == "peer" or net.lan):
        why = "a secured process is a client of the router (or the router): no --mode peer, no --lan"
        raise ConfigError("--identity", why)
    if secure and net.listen and net.mode != "router":
        raise ConfigError("--listen", "a secured process listens for nobody: only the router does")
    if net.policy and not (secure and net.mode == "router"):
        raise ConfigError("--policy", "only the router enforces a policy, and it needs its --identity")
    out: list[tuple[str, object, bool, str]] = []
    if net.connect or (net.mode == "client" and not net.lan):
        out.append(("connect/endpoints", list(net.connect) or [net.default_endpoint], bool(net.connect), "--connect"))
        out.append(("connect/timeout_ms", {"client": CONNECT_TIMEOUT_MS}, False, ""))
        out.append(("connect/retry", RETRY, False, ""))
    if net.listen or net.mode == "router":
        out.append(("listen/endpoints", list(net.listen) or [net.default_endpoint], bool(net.listen), "--listen"))
    scouting = net.lan and not secure
    out.append(("scouting/multicast/enabled", scouting, net.lan or secure, "--lan" if net.lan else "--identity"))
    out.append(("scouting/gossip/enabled", scouting, net.lan or secure, "--lan" if net.lan else "--identity"))
    out.append(("transport/link/tx/lease", LEASE_MS, False, ""))
    if secure:
        assert net.identity is not None
        out += [(k, v, True, "--identity") for k, v in tls_values(net.identity, router=net.mode == "router")]
    if net.policy:
        from iw_zenoh.secure.policy import access_control, load_policy

        out.append(("access_control", access_control(load_policy(net.policy)), True, "--policy"))
    return out


def tls_values(identity: str, *, router: bool) -> list[tuple[str, object]]:
    """The configuration values of a process joining over mutual TLS as ``identity`` (``DIR/NAME``).

    TLS is the only protocol it speaks; the router asks every client for its certificate (mTLS)
    and a client checks that the router's certificate names the host it dials.

    Raises:
        ConfigError: When a file of the identity is missing.
    """
    from iw_zenoh.secure.certs import identity_files

    ident = identity_files(identity)
    side = "listen" if router else "connect"
    values: list[tuple[str, object]] = [
        ("transport/link/protocols", ["tls"]),
        ("transport/link/tls/root_ca_certificate", str(ident.ca)),
        ("transport/link/tls/enable_mtls", True),
        (f"transport/link/tls/{side}_certificate", str(ident.cert)),
        (f"transport/link/tls/{side}_private_key", str(ident.key)),
    ]
    if not router:
        values.append(("transport/link/tls/verify_name_on_connect", True))
    return values


_MISSING = object()


def _lookup(doc: dict[str, Any], key: str) -> Any:
    """The value at ``a/b/c`` of the file as written (``_MISSING`` when it does not say)."""
    node: Any = doc
    for part in key.split("/"):
        if not isinstance(node, dict) or part not in node:
            return _MISSING
        node = node[part]
    return node


def _load_file(path: str | None) -> tuple[zenoh.Config, dict[str, Any]]:
    """The file as Zenoh reads it, and as written (to know which values it sets)."""
    if not path:
        return zenoh.Config(), {}
    try:
        conf = zenoh.Config.from_file(path)
        with open(path, encoding="utf-8") as f:
            doc = json5.load(f)
    except Exception as e:  # zenoh raises its own error type with the parser's message
        raise ConfigError("--zenoh-config", f"cannot load {path}: {e}") from None
    return conf, doc if isinstance(doc, dict) else {}


def port_in_use(port: int, host: str = "127.0.0.1") -> bool:
    """Whether something listens on ``host:port`` (TCP)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError:
            return True
    return False


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port free on ``host`` right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])
