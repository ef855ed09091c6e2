"""How ``iwz run`` reports a run that ended: when and with what (ticks, robots, collisions,
events), each criterion PASS or FAIL, the roles that were restarted, and the recording's parts."""

from __future__ import annotations

from pathlib import Path

from iw_zenoh.launch.tally import Tally
from iw_zenoh.record.parts import recording_parts
from iw_zenoh.scenario.tables import Criteria

__all__ = ["print_summary"]


def print_summary(
    tally: Tally,
    criteria: Criteria,
    *,
    recovered: dict[str, list[float]],
    record: Path | None,
    record_cut: float | None = None,
) -> bool:
    """Prints how the run ended and each criterion.

    Args:
        tally: What the launcher saw of the run.
        criteria: The scenario's criteria.
        recovered: Each restarted role's times to be back, seconds (``Restarts.recovered``).
        record: The run's recording (None: not recorded).
        record_cut: When (simulated s) the recorder could no longer write it (None: it could):
            a run asked to be recorded and recorded only in part fails.

    Returns:
        Whether every criterion is met, and the recording whole.
    """
    ok, lines = tally.verdict(criteria)
    t = tally
    print(
        f"iwz run: ended at t={t.sim_s:.1f} s (tick {t.tick}), {t.robots} robots, {t.collisions} collisions, "
        f"events {dict(sorted(t.events.items()))}"
    )
    for line in lines:
        print(f"  {line}")
    if record is not None and record_cut is not None:
        ok = False
        print(f"  FAIL recording cut off at t={record_cut:.1f} s: the recorder did not finish it (why: above)")
    for name, took in recovered.items():
        print(f"iwz run: {name} restarted {len(took)} time(s), back after " + ", ".join(f"{s:.2f} s" for s in took))
    if record is not None and record.exists():
        parts = recording_parts(record)
        more = f" in {len(parts)} parts ({', '.join(p.name for p in parts)})" if len(parts) > 1 else ""
        if record_cut is None:
            print(f"iwz run: recorded to {record}{more} (see iwz replay, iwz incidents, iwz doctor)")
        else:
            print(f"iwz run: recorded to {record}{more} until t={record_cut:.1f} s, cut off (iwz recover mends it)")
    return ok
