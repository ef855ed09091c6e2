"""The bridge's door: a budget per source address (any port), and refusals told once per address
and interval with their counts, never once per datagram."""

from __future__ import annotations

from iw_zenoh.bridges.ciberrato.guard import MAX_HOSTS, OTHERS, FloodGuard, Gate, Refusals, Report


def test_an_address_has_one_budget_whatever_its_ports() -> None:
    guard = FloodGuard(400)
    # rotating source ports: one address, one budget
    refused = [guard.over("127.0.0.1", 0.0001 * i) for i in range(1000)]
    assert refused.count(False) == 400
    assert not guard.over("127.0.0.2", 0.1)  # another address has its own
    assert not guard.over("127.0.0.1", 1.2)  # a new second, a new budget


def test_a_course_registering_from_one_machine_fits_the_registration_budget() -> None:
    gate = Gate(lambda rep: None)
    # 100 agents of one machine registering, each asking again twice, within a second
    assert all(gate.let_in(("10.0.0.5", 40000 + k % 100), None, 0.003 * k) for k in range(300))


def test_a_client_has_its_own_budget_on_its_socket() -> None:
    told: list[Report] = []
    gate = Gate(told.append, per_host=10, per_client=5)
    for _ in range(20):  # the address is over its registration budget...
        gate.let_in(("127.0.0.1", 9), None, 0.0)
    robot = ("127.0.0.1", 40001)
    assert all(gate.let_in(robot, robot, 0.0) for _ in range(5))  # ...its robot's socket is not
    assert not gate.let_in(robot, robot, 0.0)


def test_quiet_sources_are_forgotten() -> None:
    guard = FloodGuard(400)
    for host in range(MAX_HOSTS + 10):
        guard.over(f"10.0.{host // 256}.{host % 256}", 0.0)
    guard.over("10.1.0.1", 2.0)
    assert len(guard._rate) < MAX_HOSTS


def test_refusals_of_an_address_are_told_once_an_interval_with_their_count() -> None:
    r = Refusals(1.0)
    first = r.refuse(("127.0.0.1", 40000), "not well-formed XML", 10.0)
    assert first is not None  # the first one at once
    assert first.count == 1
    assert "not well-formed XML" in first.line(1.0)
    for i in range(10_000):  # then a flood from rotating ports: nothing told until the interval ends
        assert r.refuse(("127.0.0.1", 40001 + i % 3000), "junk", 10.0 + i * 1e-5, dropped=i % 2 == 0) is None
    assert r.due(10.5) == []
    [summary] = r.due(11.0)
    assert (summary.host, summary.count, summary.dropped) == ("127.0.0.1", 10_000, 5000)
    assert len(summary.ports) == 1024
    line = summary.line(1.0)
    assert "refused 10000 datagrams from 127.0.0.1" in line
    assert "5000 over the flood limit" in line
    assert "junk" in line
    assert r.due(12.0) == []  # nothing more refused: nothing more told


def test_every_address_is_told_apart_up_to_a_bound_and_the_rest_together() -> None:
    r = Refusals(1.0, max_reports=4)
    told = [r.refuse((f"10.0.0.{k}", 5000), "junk", 1.0) for k in range(50)]
    assert sum(t is not None for t in told) == 4
    due = r.due(2.0)
    others = [rep for rep in due if rep.host == OTHERS]
    assert len(others) == 1
    assert others[0].count == 46
    assert len(due) <= 4 + 1
    assert "other addresses" in others[0].line(1.0)


def test_spoofed_addresses_cost_a_bounded_table() -> None:
    r = Refusals(1.0)
    told = []
    for k in range(3 * MAX_HOSTS):
        rep = r.refuse((f"10.{k // 65536}.{k // 256 % 256}.{k % 256}", 1), "junk", 0.0)
        told += [rep] if rep else []
        assert len(r._open) <= MAX_HOSTS + 1
    told += r.due(1.0)
    assert len(told) <= 2 * (16 + 1)  # two intervals' worth of reports
    assert sum(rep.count for rep in told) == 3 * MAX_HOSTS  # every refusal counted once
