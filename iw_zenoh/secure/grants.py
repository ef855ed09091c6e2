"""What each role of a secured run may do on a simulation's keys: what it publishes, asks,
answers, which liveliness tokens it declares and what it reads (the router's rules are made of
them; docs/security.md has the table). Every key comes from :mod:`iw_zenoh.keys`, the one place
keys are spelled.
"""

from __future__ import annotations

from typing import NamedTuple

from iw_zenoh import keys

__all__ = ["POLICY_ROLES", "REGISTRARS", "Grants", "grants"]

POLICY_ROLES = (
    "world",
    "collision",
    "sensors",
    "radio",
    "recorder",
    "bridge",
    "serial",
    "viewer",
    "operator",
    "agent",
)
_TOKEN_ROLES = {
    "bridge": ("bridge", "agent"),
    "serial": ("bridge", "agent"),
    "operator": ("viewer", "launcher"),
}  # else the role itself
REGISTRARS = ("agent", "bridge", "serial")  # the roles that register robots (on their own key)


class Grants(NamedTuple):
    """What one identity may do on a simulation's keys (the router's rules are made of them).

    Attributes:
        put: Key expressions it may publish on.
        query: Those it may ask (queries).
        serve: Those it may answer (queryables).
        tokens: Liveliness tokens it may declare.
        read: Those it may subscribe to, watch and be sent.
    """

    put: tuple[str, ...]
    query: tuple[str, ...]
    serve: tuple[str, ...]
    tokens: tuple[str, ...]
    read: tuple[str, ...]


def _role_puts(role: str, sim: str, name: str, robots: tuple[int, ...], shard: tuple[int, int] | None) -> list[str]:
    own = [k(sim, r) for r in robots for k in (keys.actions, keys.say, keys.pose_report, keys.driving, keys.drive)]
    return {
        "world": [
            keys.tick(sim),
            keys.proposed(sim),
            keys.state(sim),
            keys.info(sim),
            keys.all_events(sim),
            keys.all_specs(sim),
        ],
        "collision": [keys.verdict(sim), keys.all_events(sim)],
        "sensors": [keys.sensor_batch(sim, shard) if shard else keys.all_sensor_batches(sim), keys.all_sensors(sim)]
        + [keys.all_events(sim)],
        "radio": [keys.radio(sim), keys.all_hear(sim), keys.all_events(sim)],
        "recorder": [keys.all_events(sim)],
        # a bridge's actions go in its own batch only (the world takes a batch only for the robots
        # the bridge registered): a bridge certificate cannot drive an agent's chair
        "bridge": [
            keys.agent_actions(sim, name),
            *(k(sim) for k in (keys.all_say, keys.all_pose_reports, keys.all_chairs)),
        ]
        + [keys.all_events(sim)],
        # the serial bridge answers ticks with its chair's pose and publishes the chair's readings,
        # for its chair only (its ``robots``: a serial certificate moves no other Real robot or
        # door); no actions at all (an agent commands the chair)
        "serial": [k(sim, r) for r in robots for k in (keys.pose_report, keys.chair)] + [keys.all_events(sim)],
        "agent": [keys.agent_actions(sim, name), *own, keys.event(sim, "bad-message")],
        # a viewer's pages drive only its ``robots`` (the policy's grant, per chair); so does an operator's
        "viewer": [keys.event(sim, "bad-message"), *(keys.drive(sim, r) for r in robots)],
        "operator": [keys.control(sim), keys.event(sim, "bad-message"), *(keys.drive(sim, r) for r in robots)],
    }[role]


def grants(
    roles: tuple[str, ...], sim: str, *, name: str, robots: tuple[int, ...] = (), shard: tuple[int, int] | None = None
) -> Grants:
    """What an identity playing ``roles`` may do (docs/security.md has the table).

    The world alone publishes the clock, proposals, state and its description and answers
    registration; collision alone publishes verdicts; sensors shards alone readings; the radio
    alone what is heard; an agent publishes actions, say and pose reports only for ``robots``
    and registers only on its own key; a bridge publishes actions only in its own batch (the
    world takes them only for robots it registered), the serial bridge none; control only from
    an operator; every identity reads.

    Args:
        roles: Some of :data:`POLICY_ROLES`.
        sim: The simulation.
        name: The identity (certificate common name; its liveliness and agent name).
        robots: The robots it drives (agents), whose pose it reports (a serial bridge's chair), or
            whose drive key its pages may publish on (a viewer's or an operator's: driving from the page).
        shard: The sensors shard ``(K, N)`` it computes (``None``: any).

    Raises:
        ValueError: An unknown role, or a bad name, robot id or shard.
    """
    put: list[str] = []
    query, serve, tokens = [keys.info(sim)], [], []
    for role in roles:
        if role not in POLICY_ROLES:
            raise ValueError(f"unknown role {role!r}; one of {', '.join(POLICY_ROLES)}")
        put += _role_puts(role, sim, name, tuple(keys.valid_robot_id(r) for r in robots), shard)
        tokens += [keys.alive(sim, r, name) for r in _TOKEN_ROLES.get(role, (role,))]
        if role == "world":
            serve += [keys.all_registers(sim), keys.info(sim)]
        if role in REGISTRARS:
            query.append(keys.register(sim, name))
        if role == "bridge":  # it registers legacy robots on the shared key, as a trusted registrar
            query.append(keys.register(sim))
    put_, query_, serve_, tokens_ = (tuple(dict.fromkeys(x)) for x in (put, query, serve, tokens))
    return Grants(put=put_, query=query_, serve=serve_, tokens=tokens_, read=(keys.everything(sim),))
