from __future__ import annotations

from iw_zenoh.secure.denials import REPEAT_NS, DenialLog

ZID = "a930ac09fe53c4af1f6ebb019d6d6860"
HEAD = b"\x1b[2m2026-11-24T03:29:22Z\x1b[0m \x1b[35mTRACE\x1b[0m rx-0 ThreadId(08) zenoh::net::routing::interceptor::access_control: "
FIRST = (
    HEAD
    + f"{ZID} on Interface(lo)+CertCommonName(rogue)+Transport(Tls)+{ZID} is unauthorized to Put (ingress) on iw/s/world/control".encode()
)
CACHED = HEAD + f"Using cached result: {ZID} is unauthorized to Put (ingress) on iw/s/world/control".encode()
CACHING = HEAD + b"ACL (ingress): caching permissions for `iw/s/world/state` ..."
WORKED_OUT = HEAD + f"{ZID} on CertCommonName(rogue) is unauthorized to Query (ingress) on iw/s/world/state".encode()


def test_a_refused_publication_names_the_identity_and_the_key() -> None:
    d = DenialLog().feed(FIRST, 0)
    assert str(d) == "access denied: Put from 'rogue' on iw/s/world/control"


def test_a_refusal_from_the_cache_is_named_by_the_identity_seen_before() -> None:
    log = DenialLog()
    log.feed(FIRST, 0)
    d = log.feed(CACHED, REPEAT_NS)
    assert d is not None
    assert d.identity == "rogue"


def test_a_flood_of_the_same_refusal_is_one_line_a_second_with_its_count() -> None:
    log = DenialLog()
    assert log.feed(FIRST, 0) is not None
    assert [log.feed(CACHED, i) for i in range(1, 5)] == [None] * 4
    d = log.feed(CACHED, REPEAT_NS)
    assert d is not None
    assert d.times == 5


def test_permissions_worked_out_in_advance_for_a_declared_key_are_no_refusal() -> None:
    log = DenialLog()
    assert log.feed(CACHING, 0) is None
    assert log.feed(WORKED_OUT, 0) is None


def test_other_lines_are_no_refusal() -> None:
    assert DenialLog().feed(HEAD + b"is authorized to Put (ingress) on x", 0) is None


def test_a_session_no_identity_of_the_policy_matches_is_reported_once() -> None:
    line = HEAD + f"{ZID} did not match any configured ACL subject. Default permission `Deny` will be applied".encode()
    d = DenialLog().feed(line, 0)
    assert str(d) == f"access denied: every message from 'session {ZID} (no identity of the policy)' on any key"


ALLOWED = HEAD + f"Using cached result: {ZID} is authorized to Put (ingress) on iw/s/world/state".encode()


def test_a_block_of_lines_drops_allowed_traffic_keeps_other_lines_and_finds_refusals_in_order() -> None:
    other = b"\x1b[31mERROR\x1b[0m zenoh::net::runtime: something else went wrong"
    block = b"\n".join([ALLOWED, other, FIRST, ALLOWED, CACHING, WORKED_OUT, b"iwz router: listening", b""])
    passed, found = DenialLog().read(block * 2, 0)
    assert passed == (other + b"\n" + b"iwz router: listening\n") * 2
    assert [str(d) for d in found] == ["access denied: Put from 'rogue' on iw/s/world/control"]  # the 2nd: counted


def test_a_block_of_allowed_traffic_only_passes_nothing_on() -> None:
    assert DenialLog().read((ALLOWED + b"\n") * 100, 0) == (b"", [])
