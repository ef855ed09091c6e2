"""``iwz radio``: robot-to-robot messages, delivered only within range (the logic and its limits:
:mod:`iw_zenoh.sim.radio`).

Tick n is delivered as soon as the collision verdict confirms the world's proposal (no robot
collided: :mod:`iw_zenoh.sim.early`), so a lock-step agent waiting for it does not wait for the
world's state too; in the rare tick the world held after all, the state corrects it.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.bus import Bus, Delivery, Inbox
from iw_zenoh.core.modes import Profile
from iw_zenoh.errors import IwError, ProtocolError
from iw_zenoh.messages import Proposed, Say, WorldInfo, WorldState, decode
from iw_zenoh.nodes.role_options import RadioOptions, add_radio_arguments
from iw_zenoh.process.options import options_from_args
from iw_zenoh.process.runtime import NodeIO, start_role
from iw_zenoh.sim.early import Verdicts, state_from_proposal
from iw_zenoh.sim.radio import RadioConfig, RadioNode
from iw_zenoh.ticks import TickWindow

__all__ = ["main", "run"]

logger = logging.getLogger(__name__)


def run(
    bus: Bus,
    sim: str,
    cfg: RadioConfig | None = None,
    *,
    name: str = "radio",
    io: NodeIO | None = None,
    early: bool = True,
) -> None:
    """Delivers radio messages every tick until stopped: as soon as the collision verdict
    confirms the world's proposal (unless ``early`` is false), else when the state comes."""
    io = io or NodeIO(bus, sim, "radio", name)
    loop = _Loop(io, sim, cfg, early=early)
    io.alive()
    while not io.stop.is_set():
        if not loop.once():
            io.wait(0.2)


class _Loop:
    """The radio's inboxes and the proposal and verdicts kept between passes."""

    def __init__(self, io: NodeIO, sim: str, cfg: RadioConfig | None, *, early: bool) -> None:
        self.io = io
        # in the network's order: a tick's says come before the verdict (or state) that follows
        # them, so all of them are in once it is (each subscription on its own thread, a say
        # could be overtaken and heard a tick late: not the same run twice)
        self.says = io.inbox(keys.all_say(sim), ordered=True)
        self.states = io.inbox(keys.state(sim), ordered=True)
        self.proposals = io.inbox(keys.proposed(sim), ordered=True) if early else Inbox()
        self.verdicts = io.inbox(keys.verdict(sim), ordered=True) if early else Inbox()
        self.node = RadioNode(sim, cfg)
        # the world's profile (ciberrato: the legacy limits), from each description it publishes
        # and, for a radio started after the world, asked once
        self.infos = io.inbox(keys.info(sim))
        for data in io.bus.query(keys.info(sim), timeout_s=2.0):
            self._profile(data)
        self.window = TickWindow()  # a state too far ahead is refused (its hear lists would be too)
        self.proposal: WorldState | None = None  # the newest proposal, as the state it would commit
        self.said = Verdicts()  # the verdicts of the next ticks
        self.last_tick = -1  # the newest tick delivered
        self.roster: tuple[int, list[int]] | None = None  # the newest state's revision and robots

    def once(self) -> bool:
        """One pass; False when nothing came. What was said is taken after the states and
        verdicts: a tick's messages were said before its proposal, so they are all in."""
        for _, data, _ in self.infos.drain()[-1:]:
            self._profile(data)
        states, verdicts = self.states.drain(), self.verdicts.drain()
        props, says = self.proposals.drain(), self.says.drain()
        io = self.io
        for d in says:
            msg = io.decode(d, Say)
            if msg is not None and keys.robot_id_of(d[0]) != msg.robot_id:
                io.bad_message(d[0], ProtocolError(f"a message of robot {msg.robot_id} on another robot's key"))
            elif msg is not None:
                self.node.on_say(msg)
        self._keep(props, verdicts)
        for d in states:
            self._on_state(d)
        p = self.proposal
        # the next tick goes out early only once the state of the last early one checked it: a
        # verdict may come before the state it follows (two processes, no order between them)
        if p is not None and self.node.early_tick is None and p.tick == self.last_tick + 1 and self.said.confirm(p):
            self.proposal = None
            io.send_all(self.node.send_early(p))
            self.last_tick = p.tick
        return bool(states or verdicts or props or says)

    def _profile(self, data: bytes) -> None:
        """Takes the profile of a world's description (one that does not decode changes nothing)."""
        try:
            self.node.legacy = decode(data, WorldInfo).profile == Profile.CIBERRATO
        except IwError:
            return

    def _on_state(self, d: Delivery) -> None:
        """Delivers a state's tick (or checks the one delivered early), unless it is refused."""
        io = self.io
        st = io.decode(d, WorldState)
        if st is None:
            return
        why = self.window.refuse(st.tick, time.monotonic_ns())
        if why:
            io.bad_message(d[0], ProtocolError(why))
            return
        self.roster = (st.revision, st.ids)
        self.said.settle(st)
        self._report_verdicts()
        if st.tick == self.node.early_tick:
            self._check_early(st)
            return
        early = self.node.early_tick
        if early is not None and st.tick > early:
            self.node.forget_early()  # its state will not come (a restarted world's is newer)
        io.send_all(self.node.on_state(st))
        self.last_tick = st.tick

    def _keep(self, props: list[Delivery], verdicts: list[Delivery]) -> None:
        """Keeps the newest proposal and the verdicts; each one refused is reported as a bad
        message: malformed, a tick too far ahead, robots the world's revision does not have."""
        io, now = self.io, time.monotonic_ns()
        newest: Proposed | None = None
        for d in props:
            p = io.decode(d, Proposed)
            why = self._refuse(p, now) if p is not None else ""
            if why:
                io.bad_message(d[0], ProtocolError(why))
            elif p is not None:
                newest = p
        if newest is not None:  # each is checked; only the newest is kept
            self.proposal = state_from_proposal(newest)
        self.said.take((data for _, data, _ in verdicts), lambda tick: self.window.ahead(tick, now))
        self._report_verdicts()

    def _refuse(self, p: Proposed, now_ns: int) -> str:
        """Why proposal ``p`` is refused, or ``""``."""
        if why := self.window.ahead(p.tick, now_ns):
            return why
        if len(p.rolled_left) != len(p.ids):  # a tick delivered early commits them (sim.early)
            return f"no rolled_left/rolled_right for its {len(p.ids)} robots: it cannot be delivered early"
        last = self.roster  # one revision, one roster: the world bumps it when a robot comes or goes
        if last is None or p.revision != last[0] or p.ids == last[1]:
            return ""
        ids, theirs = p.ids, last[1]
        return f"robots {ids[:5]} ({len(ids)}) not the world's at revision {p.revision}: {theirs[:5]} ({len(theirs)})"

    def _report_verdicts(self) -> None:
        """Reports each verdict refused as a bad message with its reason."""
        for why in self.said.refusals():
            self.io.bad_message(keys.verdict(self.io.sim), ProtocolError(why))

    def _check_early(self, st: WorldState) -> None:
        out = self.node.check_early(st)
        if out:
            logger.warning(
                "tick %d: delivered when the verdict confirmed the proposal, but the world committed other "
                "positions (%s): delivered again (%d such ticks so far)",
                st.tick,
                f"held: {st.held_reason}" if st.held else "not the proposal",
                self.node.corrections,
            )
            self.io.send_all(out)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz radio``."""
    return start_role(
        argv,
        role="radio",
        description="Robot-to-robot messages, delivered only to robots within range.",
        epilog=(
            "Examples (a shorter range than Ciber-Rato's 8 m):\n"
            "  iwz radio --range 4\n"
            '  iwz radio --options \'{"range_m": 4, "max_heard_bytes": 200}\'    (as iwz run starts it)\n'
            "A tick is delivered once the collision verdict confirms it; to compare,\n"
            "only once the world's state comes:\n"
            "  iwz radio --no-early"
        ),
        arguments=add_radio_arguments,
        prepare=lambda args: options_from_args(args, RadioOptions),
        run=lambda proc, o: run(proc.bus, proc.sim, _config(o), io=proc.io, early=o.early),
    )


def _config(o: RadioOptions) -> RadioConfig:
    return RadioConfig(range_m=o.range_m, max_message_bytes=o.max_message_bytes, max_heard_bytes=o.max_heard_bytes)
