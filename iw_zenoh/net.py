"""Zenoh configurations: the embedded loopback default, explicit endpoints, LAN scouting.

Default: a router on ``tcp/127.0.0.1:7447`` and every other process its client, multicast
scouting off, so nothing leaves the loopback interface unless the user asks.
"""

from __future__ import annotations

import json
import socket
from dataclasses import dataclass, field

import zenoh

from iw_zenoh.errors import ConfigError

__all__ = ["DEFAULT_ENDPOINT", "DEFAULT_PORT", "NetConfig", "free_port", "port_in_use", "zenoh_config"]

DEFAULT_PORT = 7447
DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
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
    """

    mode: str = "client"
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    lan: bool = False
    config_file: str | None = None
    overrides: tuple[str, ...] = field(default_factory=tuple)


def zenoh_config(net: NetConfig) -> zenoh.Config:
    """Builds the Zenoh configuration of one process.

    Raises:
        ConfigError: For an unknown mode, an unreadable file or a malformed override.
    """
    if net.mode not in ("client", "peer", "router"):
        raise ConfigError("--mode", f"must be client, peer or router, got {net.mode!r}")
    if net.config_file:
        try:
            conf = zenoh.Config.from_file(net.config_file)
        except Exception as e:  # zenoh raises its own error type with the parser's message
            raise ConfigError("--zenoh-config", f"cannot load {net.config_file}: {e}") from None
    else:
        conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(net.mode))
    connect = list(net.connect)
    listen = list(net.listen)
    if net.mode == "client" and not connect and not net.lan:
        connect = [DEFAULT_ENDPOINT]
    if net.mode == "router" and not listen:
        listen = [DEFAULT_ENDPOINT]
    if connect:
        conf.insert_json5("connect/endpoints", json.dumps(connect))
        conf.insert_json5("connect/timeout_ms", json.dumps({"client": CONNECT_TIMEOUT_MS}))
        conf.insert_json5("connect/retry", json.dumps(RETRY))
    if listen:
        conf.insert_json5("listen/endpoints", json.dumps(listen))
    conf.insert_json5("scouting/multicast/enabled", "true" if net.lan else "false")
    conf.insert_json5("scouting/gossip/enabled", "true" if net.lan else "false")
    conf.insert_json5("transport/link/tx/lease", str(LEASE_MS))
    for item in net.overrides:
        key, sep, value = item.partition(":")
        if not sep or not key:
            raise ConfigError("--cfg", f"expects KEY:VALUE, got {item!r}")
        try:
            conf.insert_json5(key, value)
        except Exception as e:
            raise ConfigError("--cfg", f"{key}: {e}") from None
    return conf


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
