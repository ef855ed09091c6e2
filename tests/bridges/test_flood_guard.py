"""The bridge's flood guard: a budget per peer, not per machine."""

from __future__ import annotations

from iw_zenoh.bridges.ciberrato.registrar import FloodGuard


def test_peers_of_one_address_each_have_their_own_budget() -> None:
    guard = FloodGuard(400)
    a, b = ("127.0.0.1", 40001), ("127.0.0.1", 40002)
    # a course's agents on one machine: 600 datagrams from the address within a second
    refused = [guard.over(p, 0.001 * i) for i in range(300) for p in (a, b)]
    assert not any(refused)


def test_a_peer_over_its_budget_is_refused_until_the_next_second() -> None:
    guard = FloodGuard(400)
    p = ("127.0.0.1", 40001)
    assert not any(guard.over(p, 0.5) for _ in range(400))
    assert guard.over(p, 0.9)
    assert not guard.over(p, 1.6)  # a new second, a new budget


def test_quiet_peers_are_forgotten() -> None:
    guard = FloodGuard(400)
    for port in range(5000):
        guard.over(("10.0.0.1", port), 0.0)
    guard.over(("10.0.0.2", 1), 2.0)
    assert len(guard._rate) < 5000
