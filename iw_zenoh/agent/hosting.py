"""What every process that drives robots of the world shares, the agent host and the legacy
bridge alike: a registration asked of the world until a world answers, and the outgoing path of
a robot's commands (its radio message and pose report at once, its actions on its own key or
in one batch per pass for the whole process).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, replace

from iw_zenoh import keys
from iw_zenoh.bus import Asked, Bus
from iw_zenoh.core.motor import powers_for_twist
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import DecodeError
from iw_zenoh.messages import (
    ActionBatch,
    Actions,
    PoseReport,
    RegisterReply,
    RegisterRequest,
    Say,
    decode,
    encode,
)

__all__ = ["ASK_AGAIN_S", "Command", "InlineAnswers", "Outbox", "WorldRegistration"]

ASK_AGAIN_S = 0.2  # a registration no queryable answered is asked again at most this often
KEYS_KEPT = 4096  # robots' actions keys an outbox keeps built (well above the robots of one process)


@dataclass(frozen=True)
class Command:
    """What an agent does this tick: a body velocity (:meth:`from_velocity`, what an agent of its
    own should give) or the legacy wheel powers (``Command(left, right)``, Ciber-Rato's).

    Attributes:
        left: Left motor power, [-0.15, 0.15] (``MAX_POWER``; the world clamps).
        right: Right motor power.
        say: A radio message (at most 100 bytes), or None.
        end_led: Ciber-Rato's end LED (and the other two).
        pose: For Real robots: the pose (x, y, dir_deg) from the robot's own odometry.
        actions: Publish the motor powers (False: a serial bridge reports the pose of a chair
            that another agent drives, and must not command it).
        velocity: ``(v_mps, w_radps)`` asked by :meth:`from_velocity`, or None: the agent host turns
            it into ``left`` and ``right`` through the chair's model (:meth:`resolved`).
    """

    left: float = 0.0
    right: float = 0.0
    say: str | None = None
    end_led: bool = False
    returning_led: bool = False
    visiting_led: bool = False
    pose: tuple[float, float, float] | None = None
    actions: bool = True
    velocity: tuple[float, float] | None = None

    @classmethod
    def from_velocity(
        cls,
        v_mps: float,
        w_radps: float,
        *,
        say: str | None = None,
        end_led: bool = False,
        returning_led: bool = False,
        visiting_led: bool = False,
    ) -> Command:
        """A command of a body velocity, turned into wheel powers through the chair's own model
        (its top speed and wheel base) by the agent host; one beyond the motors' reach is scaled
        down as a whole, so the chair keeps the asked curvature.

        Args:
            v_mps: Forward speed, m/s (negative: backwards).
            w_radps: Turn rate, rad/s, counter-clockwise (positive turns left).
            say: A radio message (at most 100 bytes), or None.
            end_led: Ciber-Rato's end LED.
            returning_led: Ciber-Rato's returning LED.
            visiting_led: Ciber-Rato's visiting LED.

        Returns:
            The command; its powers are set by :meth:`resolved` (a non-finite velocity stops the chair).
        """
        return cls(
            say=say,
            end_led=end_led,
            returning_led=returning_led,
            visiting_led=visiting_led,
            velocity=(float(v_mps), float(w_radps)),
        )

    @classmethod
    def stop(cls) -> Command:
        """Both motors at rest."""
        return cls(0.0, 0.0)

    def resolved(self, spec: RobotSpec) -> Command:
        """This command in wheel powers for the chair ``spec`` describes (itself when it has no velocity).

        Args:
            spec: The chair's registered spec (its ``max_speed_mps`` and ``wheel_base_m``).

        Returns:
            A command with ``left`` and ``right`` set and no velocity.
        """
        if self.velocity is None:
            return self
        left, right = powers_for_twist(*self.velocity, spec.max_speed_mps, spec.wheel_base_m)
        return replace(self, left=left, right=right, velocity=None)


class Outbox:
    """A process's outgoing path for the robots it drives.

    Args:
        bus: The bus.
        sim: Simulation name.
        agent: The process's agent name (the key of its batches).
        batched: Keep each robot's newest actions and send them all in one :class:`ActionBatch`
            on :meth:`flush`; otherwise each robot's actions go at once on its own key.
    """

    def __init__(self, bus: Bus, sim: str, agent: str, *, batched: bool) -> None:
        self.bus = bus
        self.sim = sim
        self.agent = agent
        self.batched = batched
        self._batch: dict[int, Actions] = {}  # robot -> newest actions not yet sent
        self._keys: dict[int, str] = {}  # robot -> its actions key (built once, not every tick)

    def command(self, robot_id: int, cmd: Command, *, tick: int, sim_time_ns: int) -> Actions:
        """Sends a robot's radio message and pose report now; its actions now or with the batch.

        Args:
            robot_id: The robot.
            cmd: What it does.
            tick: The tick its command answers (the tick of the readings it was made from).
            sim_time_ns: That tick's simulation time.

        Returns:
            The robot's actions, as sent or queued (or, with ``cmd.actions`` false, as not sent).
        """
        if cmd.say is not None:
            say = Say(tick=tick, sim_time_ns=sim_time_ns, robot_id=robot_id, text=cmd.say)
            self.bus.publish(keys.say(self.sim, robot_id), encode(say))
        if cmd.pose is not None:
            x, y, d = cmd.pose
            report = PoseReport(tick=tick, sim_time_ns=sim_time_ns, robot_id=robot_id, x=x, y=y, dir_deg=d)
            self.bus.publish(keys.pose_report(self.sim, robot_id), encode(report))
        act = Actions(
            tick=tick,
            sim_time_ns=sim_time_ns,
            robot_id=robot_id,
            left=cmd.left,
            right=cmd.right,
            end_led=cmd.end_led,
            returning_led=cmd.returning_led,
            visiting_led=cmd.visiting_led,
        )
        if not cmd.actions:
            return act  # a pose alone: another agent commands this robot
        if self.batched:
            self._batch[robot_id] = act
        else:
            key = self._keys.get(robot_id)
            if key is None:
                if len(self._keys) >= KEYS_KEPT:  # robots come and go for hours: only the recent ones'
                    self._keys.clear()
                key = self._keys[robot_id] = keys.actions(self.sim, robot_id)
            self.bus.publish(key, encode(act))
        return act

    def flush(self) -> None:
        """Sends the queued actions, every robot's in one message stamped with the newest tick."""
        if not self._batch:
            return
        acts = list(self._batch.values())
        self._batch.clear()
        last = max(acts, key=lambda a: a.tick)
        batch = ActionBatch(tick=last.tick, sim_time_ns=last.sim_time_ns, agent=self.agent, actions=acts)
        self.bus.publish(keys.agent_actions(self.sim, self.agent), encode(batch))


class WorldRegistration:
    """One robot's registration, asked of the world without waiting; asked again while no world
    answers (a world still starting) until ``patience_s`` has passed.

    Args:
        bus: The bus.
        sim: Simulation name.
        request: The registration.
        now: The time of asking, in seconds of a monotonic clock (the caller's).
        patience_s: How long a registration no world answers is asked again.
        query_timeout_s: How long one ask waits for its answers.
        own_key: Ask on the agent's own registration key (``world/register/{agent}``, what a
            secured router lets only that agent ask on) instead of the shared one.
    """

    def __init__(
        self,
        bus: Bus,
        sim: str,
        request: RegisterRequest,
        *,
        now: float,
        patience_s: float,
        query_timeout_s: float,
        own_key: bool = False,
    ) -> None:
        self.bus = bus
        self.key = keys.register(sim, request.agent if own_key else "")
        self.request = request
        self.payload = encode(request)
        self.since = now
        self.patience_s = patience_s
        self.query_timeout_s = query_timeout_s
        self.asked_at = now
        self.asked: Asked = bus.ask(self.key, self.payload, timeout_s=query_timeout_s)

    def poll(self, now: float) -> bool:
        """Whether the registration is over (answered, or no world answered in time); asks again
        when the last ask went unanswered and ASK_AGAIN_S has passed since it.

        Args:
            now: Seconds, of the clock ``now`` was given in at construction.
        """
        if not self.asked.answered():
            return False
        if self.asked.replies or now - self.since >= self.patience_s:
            return True
        if now - self.asked_at >= ASK_AGAIN_S:  # no queryable answers at once: not in a busy loop
            self.asked = self.bus.ask(self.key, self.payload, timeout_s=self.query_timeout_s)
            self.asked_at = now
        return False

    def wait(self, stop: threading.Event, now: float) -> None:
        """Blocks until the next :meth:`poll` has something to do, or ``stop`` is set.

        Args:
            stop: Set when the caller is stopping.
            now: Seconds, of the clock ``now`` was given in at construction.
        """
        if not self.asked.answered():
            self.asked.done.wait(self.query_timeout_s)  # every answer in, or the query's timeout
        else:
            stop.wait(max(0.0, ASK_AGAIN_S - (now - self.asked_at)))

    def reply(self) -> RegisterReply | None:
        """The world's answer (the first that decodes: one that does not, from some other
        queryable, is passed over), or None when no world answered.

        Raises:
            DecodeError: When no answer decodes (the first one's reason).
        """
        refused: DecodeError | None = None
        for data in list(self.asked.replies):
            try:
                return decode(data, RegisterReply)
            except DecodeError as e:
                refused = refused or e
        if refused is not None:
            raise refused
        return None


class InlineAnswers:
    """The wake of an agent host's readings and radio inboxes: the thread that delivers a tick's
    last input answers the tick itself.

    A delivery used to set the host loop's event, and the loop's thread woke to answer: two
    threads woken per tick, and the hand-off (a condition's notify, a futex wake, the GIL passed
    on) cost an agent process about a third of its CPU per tick. While :attr:`active` (the host's
    ``run``), a delivery takes the host's lock and answers at once on its own thread; when the
    lock is held (the loop is answering or checking its other inboxes), it sets the loop's event
    instead, so the loop passes once more and nothing waits unseen. Answers stay one at a time,
    under :attr:`lock`, in the order of the ticks.

    Args:
        answer: Answers what is ready, without waiting (called under :attr:`lock`).
        wake: The host loop's event.
    """

    def __init__(self, answer: Callable[[], object], wake: threading.Event) -> None:
        self.lock = threading.Lock()
        self.active = False
        self.failure: BaseException | None = None  # raised by an answer on a delivering thread, for the loop
        self._answer = answer
        self._wake = wake

    def is_set(self) -> bool:
        """Never set: every delivery is a chance to answer."""
        return False

    def set(self) -> None:
        """A delivery: answers on this thread when the lock is free, else wakes the loop."""
        if not self.active or self.failure is not None or not self.lock.acquire(blocking=False):
            self._wake.set()
            return
        try:
            self._answer()
        except BaseException as e:  # an agent's error ends the process from its loop, as before
            self.failure = e
            self._wake.set()
        finally:
            self.lock.release()
