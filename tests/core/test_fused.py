"""The fused tick refuses arrays that do not fit its roster before its kernel reads them (the
kernels do not check their indices: a short array would be read past its end)."""

from __future__ import annotations

import numpy as np
import pytest

from iw_zenoh.core import fused
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.read_all import _fixed
from iw_zenoh.core.spec import prototype_chair
from iw_zenoh.core.world import drive_table


@pytest.mark.parametrize(
    "bad",
    ["pose", "prev", "cmd", "z", "acc", "z_motion"],
)
def test_an_array_that_does_not_fit_the_roster_is_refused_with_the_shapes(bad: str) -> None:
    scene = Scene(Lab("t", 6.0, 6.0, ()))
    bodies = Bodies.from_specs([prototype_chair("a"), prototype_chair("b")])
    fixed = fused.fixed_args(scene, bodies, drive_table(bodies), np.zeros(2, dtype=bool), 0.1, (0.0, 0.0))
    assert fixed[:2] == (2, _fixed(bodies)[0])
    good = {
        "pose": np.zeros((2, 3)),
        "prev": np.zeros((2, 2)),
        "cmd": np.zeros((2, 2)),
        "z_motion": np.zeros((2, 2)),
        "z": np.zeros(fixed[1]),
        "acc": np.zeros((2, 2)),
    }
    good[bad] = np.zeros((1, 2)) if good[bad].ndim == 2 else np.zeros(fixed[1] - 1)
    with pytest.raises(ValueError, match=r"2 robots, \d+ normals"):
        fused.tick(good["pose"], good["prev"], good["cmd"], good["z_motion"], good["z"], good["acc"], fixed)
