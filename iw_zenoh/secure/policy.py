"""The security policy (TOML): which identity plays which role; the router's rules made from it.

A policy names the simulation and, for each identity (a certificate's common name), its role or
roles, the robots an agent drives and the shard a sensors process computes::

    sim = "default"

    [identities.world]
    role = "world"

    [identities.alice]
    role = "agent"
    robots = [1, 2]

    [identities."sensors-1"]
    role = "sensors"
    shard = "1/2"

:func:`access_control` turns it into Zenoh's ``access_control`` configuration: default deny,
one subject per identity (by certificate common name), and the rules of
:func:`iw_zenoh.secure.grants.grants`. See docs/security.md.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Annotated, Any

import msgspec

from iw_zenoh import keys
from iw_zenoh.errors import ConfigError
from iw_zenoh.messages.wire import INT64_MAX
from iw_zenoh.secure.grants import POLICY_ROLES, Grants, grants

__all__ = ["IdentityEntry", "Policy", "access_control", "load_policy", "owners", "parse_policy"]

NAME_PATTERN = r"^[^/*$?#\s]+$"
SHARD_PATTERN = r"^(\d+/\d+)?$"
Name = Annotated[str, msgspec.Meta(pattern=NAME_PATTERN)]


class IdentityEntry(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[identities.NAME]``: what the identity NAME may do.

    Attributes:
        role: One of :data:`iw_zenoh.secure.grants.POLICY_ROLES`, or a list of them (a legacy bridge that
            also starts and pauses the world: ``["bridge", "operator"]``).
        robots: The robots an agent drives (their ids); the world registers no other for it. A
            viewer's (or operator's): the chairs its pages may drive (their ``robot/{id}/drive``).
        shard: A sensors process's shard, ``K/N`` ("": any shard).
        hosts: Names or addresses its certificate is also valid for (``iwz secure issue --host``).
    """

    role: str | list[str]
    robots: list[Annotated[int, msgspec.Meta(ge=1, le=INT64_MAX)]] = []
    shard: Annotated[str, msgspec.Meta(pattern=SHARD_PATTERN)] = ""
    hosts: list[str] = []

    @property
    def roles(self) -> tuple[str, ...]:
        """Its roles."""
        return (self.role,) if isinstance(self.role, str) else tuple(self.role)

    @property
    def shard_pair(self) -> tuple[int, int] | None:
        """Its shard as ``(K, N)``, or ``None`` for any."""
        if not self.shard:
            return None
        k, n = self.shard.split("/")
        return int(k), int(n)


class Policy(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A whole policy: the simulation it guards and every identity."""

    sim: Name = "default"
    identities: dict[Name, IdentityEntry] = {}


_PATTERNS = {  # what a refused pattern means, in the words of the policy's reader
    NAME_PATTERN: "a name (an identity's, or sim) is text without /, *, $, ?, # or spaces, e.g. alice or sensors-1",
    SHARD_PATTERN: 'a shard is "K/N", e.g. "1/2" (or "" for any)',
}


def _readable(reason: str) -> str:
    """A msgspec refusal with the regular expression it quotes replaced by what it means."""
    for pattern, says in _PATTERNS.items():
        quoted = f"Expected `str` matching regex {pattern!r}"
        if quoted in reason:
            return reason.replace(quoted, says)
    return reason


def parse_policy(text: str, name: str = "policy") -> Policy:
    """Reads a policy from TOML text.

    Raises:
        ConfigError: Naming the field (``identities.alice.role``) and the reason.
    """
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(name, f"not valid TOML: {e}; fix the file (its format: docs/security.md)") from None
    try:
        policy = msgspec.convert(doc, Policy)
    except msgspec.ValidationError as e:
        raise ConfigError(name, _readable(str(e).replace("$.", ""))) from None
    owner: dict[int, str] = {}
    for ident, entry in policy.identities.items():
        where = f"{name}: identities.{ident}"
        if not entry.roles:
            raise ConfigError(f"{where}.role", f"no role; give one of {', '.join(POLICY_ROLES)}")
        for role in entry.roles:
            if role not in POLICY_ROLES:
                raise ConfigError(f"{where}.role", f"unknown role {role!r}; one of {', '.join(POLICY_ROLES)}")
        try:
            grants(entry.roles, policy.sim, name=ident, robots=tuple(entry.robots), shard=entry.shard_pair)
        except ValueError as e:
            raise ConfigError(f"{where}.shard", str(e)) from None
        if entry.robots and not {"agent", "serial", "viewer", "operator"} & set(entry.roles):
            raise ConfigError(
                f"{where}.robots",
                "only an agent drives robots of its own (a serial bridge reports its chair, a viewer's pages drive "
                "its chairs)",
            )
        for r in entry.robots if "agent" in entry.roles else ():  # a serial bridge's chair is an agent's too
            if r in owner:
                who = "listed twice" if owner[r] == ident else f"driven by {owner[r]!r} already"
                raise ConfigError(f"{where}.robots", f"robot {r} is {who}")
            owner[r] = ident
    return policy


def load_policy(path: str | Path) -> Policy:
    """Reads a policy file.

    Raises:
        ConfigError: Naming the file, the field and the reason.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise ConfigError(
            str(p),
            f"cannot read the policy ({e.strerror}); give the policy.toml `iwz secure init DIR` made, "
            "or make one with `iwz secure init DIR` and `iwz secure issue NAME --role ROLE --dir DIR`",
        ) from None
    except UnicodeDecodeError as e:
        raise ConfigError(str(p), f"not a text file ({e.reason} at byte {e.start}); give the policy's TOML") from None
    return parse_policy(text, str(p))


def owners(policy: Policy) -> dict[str, tuple[int, ...] | None]:
    """Every identity that registers robots, and the robots the world registers for it: an
    agent's own, a serial bridge's chair (its ``robots``), any for a bridge (a trusted registrar
    of legacy robots, whose clients choose their ids: the world refuses it an agent's robot)."""
    out: dict[str, tuple[int, ...] | None] = {}
    for n, e in policy.identities.items():
        if "agent" in e.roles or "serial" in e.roles:
            out[n] = tuple(e.robots)
        elif "bridge" in e.roles:
            out[n] = None
    return out


def _rule(rule_id: str, messages: list[str], flows: list[str], key_exprs: tuple[str, ...]) -> dict[str, Any]:
    return {"id": rule_id, "messages": messages, "flows": flows, "permission": "allow", "key_exprs": list(key_exprs)}


def _identity_rules(ident: str, g: Grants) -> list[dict[str, Any]]:
    """The rules that let one identity do what its grants say (ingress: from it; egress: to it)."""
    rules = [
        _rule(f"{ident}/put", ["put"], ["ingress"], g.put),
        _rule(f"{ident}/query", ["query"], ["ingress"], g.query),
        _rule(f"{ident}/answers", ["reply"], ["egress"], g.query),
        _rule(f"{ident}/token", ["liveliness_token"], ["ingress"], g.tokens),
    ]
    if g.serve:
        rules.append(_rule(f"{ident}/serve", ["declare_queryable", "reply"], ["ingress"], g.serve))
        rules.append(_rule(f"{ident}/asked", ["query"], ["egress"], g.serve))
    return [r for r in rules if r["key_exprs"]]


def access_control(policy: Policy) -> dict[str, Any]:
    """The router's ``access_control`` configuration for ``policy``: default deny, a subject per
    identity by certificate common name, each allowed what :func:`iw_zenoh.secure.grants.grants` says.

    Every identity reads the whole simulation (subscriptions, publications sent to it, who
    subscribes and answers what, liveliness of every process); nothing else is allowed unless
    granted.
    """
    read = (keys.everything(policy.sim),)
    alive = (keys.all_alive(policy.sim),)
    rules = [
        _rule("read", ["put"], ["egress"], read),
        _rule("subscribe", ["declare_subscriber"], ["ingress"], read),
        _rule("see-declarations", ["declare_subscriber", "declare_queryable"], ["egress"], read),
        _rule("read-answers", ["reply"], ["egress"], read),
        _rule("watch-alive", ["declare_liveliness_subscriber", "liveliness_query"], ["ingress"], alive),
        _rule("see-alive", ["liveliness_token"], ["egress"], alive),
    ]
    common = [r["id"] for r in rules]
    subjects, policies = [], []
    for ident, entry in policy.identities.items():
        g = grants(entry.roles, policy.sim, name=ident, robots=tuple(entry.robots), shard=entry.shard_pair)
        own = _identity_rules(ident, g)
        rules += own
        subjects.append({"id": ident, "cert_common_names": [ident]})
        policies.append({"id": ident, "rules": common + [r["id"] for r in own], "subjects": [ident]})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies}
