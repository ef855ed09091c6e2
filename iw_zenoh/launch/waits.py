"""How ``iwz run`` waits for its processes to be up: the router listening on its port, and a
number of each role's liveliness tokens on the bus, each wait bounded and given up when the run
stops or a process could not start."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import NetConfig, port_in_use
from iw_zenoh.launch.child import Child

__all__ = ["wait_listening", "wait_roles"]

POLL_S = 0.05  # how often the router's port is tried


def wait_listening(router: Child, port: int, host: str, timeout_s: float) -> bool:
    """Waits until something listens on ``host``:``port``.

    Args:
        router: The router's child process: the wait ends (False) when it has died.
        port: The router's TCP port.
        host: The address it listens on.
        timeout_s: The longest wait, seconds.

    Returns:
        Whether the port was taken within ``timeout_s`` with the router alive.
    """
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if port_in_use(port, host):
            return True
        if not router.alive():
            return False
        time.sleep(POLL_S)
    return False


def wait_roles(
    net: NetConfig,
    sim: str,
    roles: dict[str, int],
    timeout_s: float,
    *,
    stop: threading.Event,
    failed: Callable[[], bool],
) -> bool:
    """Waits until at least ``roles[role]`` processes of each role are alive (their liveliness tokens).

    Args:
        net: How to join the bus (a session of its own, closed on return).
        sim: Simulation name.
        roles: The number of processes of each role to wait for.
        timeout_s: The longest wait, seconds.
        stop: Set when the run stops: the wait ends (False).
        failed: Asked every 0.1 s whether a process could not start: the wait ends (False) when True.

    Returns:
        Whether every role was up.
    """
    seen: dict[str, set[str]] = {r: set() for r in roles}
    done = threading.Event()

    def on_alive(key: str, alive: bool) -> None:
        parts = keys.alive_parts(key)
        if parts and parts[0] in seen and alive:
            seen[parts[0]].add(parts[1])
            if all(len(seen[r]) >= n for r, n in roles.items()):
                done.set()

    bus = ZenohBus(net)
    try:
        bus.watch_alive(keys.all_alive(sim), on_alive)
        deadline = time.monotonic() + timeout_s
        while not done.wait(0.1):
            if stop.is_set() or time.monotonic() > deadline or failed():
                return False
        return True
    finally:
        bus.close()
