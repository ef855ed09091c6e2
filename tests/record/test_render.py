from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from iw_zenoh.errors import IwError
from iw_zenoh.record.render import render

SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "demo-sample.mcap"


def test_a_moment_of_the_sample_recording_is_drawn(tmp_path: Path) -> None:
    out = tmp_path / "moment.png"
    with SAMPLE.open("rb") as f:
        tick = render(f, out, at_s=20.0, window_s=5.0, robot=1)
    assert tick == 200
    img = matplotlib.image.imread(out)
    assert img.shape[1] > img.shape[0] > 200  # two panels side by side
    assert float(np.std(img[..., :3])) > 0.05  # something was drawn, not a blank canvas


def test_a_time_without_state_is_refused(tmp_path: Path) -> None:
    with SAMPLE.open("rb") as f, pytest.raises(IwError, match="no world state"):
        render(f, tmp_path / "x.png", at_s=500.0, window_s=1.0)


def test_importing_render_leaves_the_matplotlib_backend_alone() -> None:
    code = "import iw_zenoh.record.render, matplotlib; print(matplotlib.get_backend())"
    env = {**os.environ, "MPLBACKEND": "svg"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env, check=True)
    assert r.stdout.strip() == "svg"
