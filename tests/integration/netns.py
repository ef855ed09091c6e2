"""Two hosts on one machine: network namespaces joined by a veth pair, private addresses only.

Needs root and iproute2; the namespaces (and the veth pair with them) are removed afterwards
whatever happens.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=20)


@contextmanager
def two_hosts(letter: str, subnet: str) -> Iterator[tuple[str, str, str]]:
    """Two namespaces joined by a veth pair: yields (ns_a, ns_b, address of a); always removed.

    Args:
        letter: One letter told apart from other users' namespaces and devices (``iw<letter>a…``,
            ``<letter>a…``), so that two tests never share names.
        subnet: The first two octets and the base of the third, e.g. ``"10.231.200"``: the pair
            takes ``<a>.<b>.<base + pid % 50>.1`` and ``.2``.

    Example:
        >>> with two_hosts("z", "10.231.200") as (ns_a, ns_b, addr_a):  # doctest: +SKIP
        ...     subprocess.run(["ip", "netns", "exec", ns_a, "true"], check=True)
    """
    assert shutil.which("ip"), "iproute2 is needed for the multi-host test (apt-get install iproute2)"
    assert os.geteuid() == 0, "the multi-host test creates network namespaces and must run as root"
    tag = f"{os.getpid() % 100000}"
    a, b = f"iw{letter}a{tag}", f"iw{letter}b{tag}"
    dev_a, dev_b = f"{letter}a{tag}", f"{letter}b{tag}"
    prefix, _, base = subnet.rpartition(".")
    net = f"{prefix}.{int(base) + os.getpid() % 50}"
    addr_a, addr_b = f"{net}.1", f"{net}.2"
    try:
        _ip("netns", "add", a)
        _ip("netns", "add", b)
        _ip("link", "add", dev_a, "type", "veth", "peer", "name", dev_b)
        _ip("link", "set", dev_a, "netns", a)
        _ip("link", "set", dev_b, "netns", b)
        for ns, dev, addr in ((a, dev_a, addr_a), (b, dev_b, addr_b)):
            _ip("-n", ns, "addr", "add", f"{addr}/24", "dev", dev)
            _ip("-n", ns, "link", "set", dev, "up")
            _ip("-n", ns, "link", "set", "lo", "up")
        yield a, b, addr_a
    finally:
        for ns in (a, b):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=20)
