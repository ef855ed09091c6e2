"""Compiled kernels are cached on disk and loaded, not compiled, by every process after the first
(issue #23): two fresh interpreters warm the sensors' kernels up in turn over one cache folder
(``NUMBA_CACHE_DIR``, as an installed package in a read-only place would use, or numba's per-user
cache); the first writes the cache's index files, the second compiles nothing (a kernel another
calls is in its caller's cached code, so the second process never compiles it either)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

WARM_UP = """
import json
from numba.core.registry import CPUDispatcher
from iw_zenoh.core import cellgrid, collide, cones, contact, drive, laser, placing, read_all, readout

cones.warm_up()
drive.warm_up()
laser.warm_up()
placing.warm_up()
readout.warm_up()
collide.warm_up()
read_all.warm_up()
stats = {}
for module in (cones, laser, cellgrid, placing, readout, contact, collide, read_all, drive):
    for name, obj in vars(module).items():
        if isinstance(obj, CPUDispatcher) and obj.signatures:
            s = obj.stats
            stats[f"{module.__name__}.{name}"] = [sum(s.cache_hits.values()), sum(s.cache_misses.values())]
print(json.dumps(stats))
"""


def _warm_up(cache: Path) -> dict[str, list[int]]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    done = subprocess.run(
        [sys.executable, "-c", WARM_UP], env=env, capture_output=True, text=True, timeout=240, check=False
    )
    assert done.returncode == 0, done.stderr
    stats: dict[str, list[int]] = json.loads(done.stdout.strip().splitlines()[-1])
    return stats


def test_a_second_process_loads_every_kernel_from_the_disk_cache(tmp_path: Path) -> None:
    cache = tmp_path / "numba-cache"
    first = _warm_up(cache)
    kernels = ["iw_zenoh.core.cones._scan", "iw_zenoh.core.laser._scan", "iw_zenoh.core.placing.wedges"]
    kernels += ["iw_zenoh.core.collide._collide", "iw_zenoh.core.read_all._read"]
    kernels += ["iw_zenoh.core.drive.propose_into", "iw_zenoh.core.drive.commit_into"]
    assert set(kernels) <= set(first)
    assert all(misses >= 1 for _, misses in first.values())  # compiled: nothing was there yet
    assert list(cache.rglob("*.nbi")), "the first process wrote no cache index"

    second = _warm_up(cache)  # the kernels the warm-ups call, loaded with what they call inlined
    assert {name: misses for name, (_, misses) in second.items()} == dict.fromkeys(second, 0)
    for entry in kernels:
        assert second[entry][0] >= 1, f"{entry} did not come from the cache"
