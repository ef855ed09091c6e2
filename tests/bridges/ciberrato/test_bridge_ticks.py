"""The bridge's Zenoh side refuses a tick too far ahead of the world's (a state of tick 10^15
would finish the legacy game; a sensor batch of it would silence every legacy robot)."""

from __future__ import annotations

from iw_zenoh.bridges.ciberrato.node import Bridge

from iw_zenoh import keys
from iw_zenoh.messages import Event, SensorBatch, Tick, WorldState, decode, encode
from tests.support.fakes import FakeBus, FakeTransport, Transports

FAR = 10**15


def _state(tick: int) -> WorldState:
    return WorldState(
        tick=tick, revision=1, ids=[], x=[], y=[], heading=[], collided=[], rolled_left=[], rolled_right=[], speed=[]
    )


def test_a_state_a_batch_and_a_tick_from_far_ahead_are_refused_naming_their_keys() -> None:
    bus = FakeBus()
    bridge = Bridge(bus, "s", FakeTransport(), new_transport=Transports(), pace=False)
    try:
        bus.queues[keys.state("s")].put(keys.state("s"), encode(_state(10)))
        bridge.pump_bus()
        assert bridge.window.newest == 10
        batch = keys.sensor_batch("s", (1, 1))
        bus.queues[keys.state("s")].put(keys.state("s"), encode(_state(FAR)))
        bus.queues[keys.all_sensor_batches("s")].put(batch, encode(SensorBatch(tick=FAR, shard="1-1")))
        bus.queues[keys.tick("s")].put(keys.tick("s"), encode(Tick(tick=FAR, period_ns=1, running=False)))
        bridge.pump_bus()
        bad = [decode(d, Event) for k, d in bus.published if k == keys.event("s", "bad-message")]
        assert [e.key for e in bad] == [keys.state("s"), batch, keys.tick("s")]
        assert all("ahead of the world's tick 10" in e.reason for e in bad)
        assert bridge.referee.finished_at is None
        assert bridge.running  # the forged tick did not stop it either
        bus.queues[keys.state("s")].put(keys.state("s"), encode(_state(11)))
        bridge.pump_bus()
        assert bridge.window.newest == 11
    finally:
        bridge.close()
