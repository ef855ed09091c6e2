"""The usual tick's readings in one compiled call (core.read_all, taken by read_sensors when every
robot is computed, without beacons or Ciber-Rato's IR model) are the separate path's, bit for bit:
the separate path (each sensor kind's own calls, what read_sensors did before, kept for shards,
beacons and Ciber-Rato) is the oracle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from iw_zenoh.core import sensors
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Lab, Scene, Target
from iw_zenoh.core.read_all import read_all
from iw_zenoh.core.sensor_noise import noise_layout
from iw_zenoh.core.spec import BumperSpec, IrSensorSpec, LaserSpec, NoiseSpec, RobotSpec, SensorNoise
from tests.support.builders import random_poses, random_scene

SPECIAL_HEADINGS = (0.0, -0.0, np.pi, -np.pi, 1e6, -3e9, 2.5e-300)


def _noise(g: np.random.Generator) -> SensorNoise:
    def one() -> NoiseSpec:
        return NoiseSpec(float(g.uniform(-0.5, 0.5)), float(g.uniform(0.0, 2.0)), enabled=bool(g.random() < 0.8))

    return SensorNoise(
        proximity_m=one(),
        proximity_legacy=one(),
        compass_deg=one(),
        gps_m=one(),
        gps_heading_deg=one(),
        encoder_slip=one(),
        laser_m=one(),
    )


def _world(seed: int) -> tuple[Scene, Bodies, np.ndarray]:
    g = np.random.default_rng(seed)
    scene = random_scene(g)
    if g.random() < 0.3:  # targets (ground is read beside the compiled call)
        lab = scene.lab
        scene = Scene(Lab(lab.name, lab.width_m, lab.height_m, lab.walls, targets=(Target(5.0, 5.0, 3.0),)))
    n = int(g.integers(1, 6))
    specs = []
    for i in range(n):
        cones = tuple(
            IrSensorSpec(k, g.uniform(-0.5, 0.5), g.uniform(-0.3, 0.3), g.uniform(-180, 180), g.uniform(1, 170), g.uniform(0.5, 6.0))
            for k in range(int(g.integers(0, 6)))
        )  # fmt: skip
        lasers = tuple(
            LaserSpec(k, g.uniform(-0.5, 0.5), g.uniform(-0.3, 0.3), g.uniform(-180, 180), g.uniform(1, 360), int(g.integers(1, 40)), g.uniform(0.5, 15.0))
            for k in range(int(g.integers(0, 3)))
        )  # fmt: skip
        bumpers = (BumperSpec(0, ((0.2, -0.3), (0.7, -0.3), (0.7, 0.3))),) if g.random() < 0.3 else ()
        specs.append(
            RobotSpec(
                f"r{i}",
                id=i + 1,
                width_m=g.uniform(0.3, 1.5),
                height_m=g.uniform(0.3, 1.0),
                com=g.uniform(0.1, 0.9),
                ir_sensors=cones,
                lasers=lasers,
                bumpers=bumpers,
                noise=_noise(g),
            )
        )
    pose = random_poses(g, n)
    if g.random() < 0.3:  # near or on top of one another, or outside the lab
        pose[:, :2] = pose[0, :2] + g.normal(0.0, 0.4, (n, 2))
    if g.random() < 0.2:
        pose[0, :2] = g.uniform(-30.0, 40.0, 2)
    if g.random() < 0.3:
        pose[:, 2] = g.choice(SPECIAL_HEADINGS, n)
    return scene, Bodies.from_specs(specs), pose


def _bits(a: np.ndarray) -> np.ndarray:
    return a.view(np.int64) if a.dtype == np.float64 else a


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-5.0, 5.0), st.floats(-5.0, 5.0))
def test_the_compiled_tick_reads_what_the_separate_path_reads(seed: int, off_x: float, off_y: float) -> None:
    scene, bodies, pose = _world(seed)
    g = np.random.default_rng(seed + 1)
    n = bodies.n
    counts, _ = noise_layout(bodies, 0)
    z = g.standard_normal(int(counts.sum()))
    acc = g.uniform(-1e3, 1e3, (n, 2))
    rolled = g.uniform(-0.1, 0.1, (n, 2))
    collided = g.random(n) < 0.5
    params = sensors.SensorParams(gps_offset_m=(off_x, off_y))
    got = sensors.read_sensors(
        scene, bodies, pose, collided=collided, encoder_acc=acc, rolled_m=rolled, z=z, params=params
    )
    want = sensors._separately(scene, bodies, pose, collided, acc, rolled, z, params, None, False, ())
    for field in sensors.Readings.__dataclass_fields__:
        a, b = getattr(got, field), getattr(want, field)
        assert a.shape == b.shape, field
        assert a.dtype == b.dtype, field
        np.testing.assert_array_equal(_bits(a), _bits(b), err_msg=field)


def test_arrays_of_the_wrong_size_are_refused_not_read_past_their_end() -> None:
    scene, bodies, pose = _world(7)
    n = bodies.n
    need = int(noise_layout(bodies, 0)[0].sum())
    ok = {"z": np.zeros(need), "encoder_acc": np.zeros((n, 2)), "rolled_m": np.zeros((n, 2))}
    read_all(scene, bodies, pose, ok["z"], ok["encoder_acc"], ok["rolled_m"], (0.0, 0.0))
    for name, bad in (("z", np.zeros(need - 1)), ("encoder_acc", np.zeros((n + 1, 2))), ("rolled_m", np.zeros((n, 1)))):
        args = {**ok, name: bad}
        with pytest.raises(ValueError, match="robots"):
            read_all(scene, bodies, pose, args["z"], args["encoder_acc"], args["rolled_m"], (0.0, 0.0))
    with pytest.raises(ValueError, match="robots"):
        read_all(
            scene,
            bodies,
            pose[:-1] if n > 1 else np.zeros((2, 3)),
            ok["z"],
            ok["encoder_acc"],
            ok["rolled_m"],
            (0.0, 0.0),
        )
