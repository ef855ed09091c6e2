"""The 200-case sweep of damaged recordings (issue 34): how many copies ``iwz recover`` turns into
files ``iwz doctor`` calls whole whose messages differ, and how many a reader takes in silence.

    .venv/bin/python -m benchmarks.damaged_recordings [CASES]

Each case is one seeded damaged copy (flipped bits, a truncation, a zeroed range, two chunks
swapped) of a small recording made from recordings/demo-sample.mcap; tests/record/test_damaged_corpus.py
runs a few dozen of the same cases.
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from tests.support.damage import KINDS, damaged, judge, small_recording


def main() -> int:
    cases = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    data = small_recording()
    t0 = time.perf_counter()
    failures: Counter[str] = Counter()
    bad_cases = 0
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        original = tmp / "original.mcap"
        original.write_bytes(data)
        for i in range(cases):
            kind = KINDS[i % len(KINDS)]
            wrong = judge(original, damaged(data, kind, 1000 + i), tmp)
            bad_cases += bool(wrong)
            for w in wrong:
                failures[w.split(":")[0][:90]] += 1
                print(f"case {i} ({kind}, seed {1000 + i}): {w}")
    print(f"{cases} cases in {time.perf_counter() - t0:.1f} s; {bad_cases} handled wrongly")
    for w, n in failures.most_common():
        print(f"  {n:4d}  {w}")
    return 1 if bad_cases else 0


if __name__ == "__main__":
    raise SystemExit(main())
