"""An installed package, not a checkout: from a built wheel, in a folder that holds nothing,
``iwz scenarios`` lists what ships and ``iwz run demo`` passes (issue: an installed package had no
scenario to run)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from iw_zenoh.bus.net import free_port
from iw_zenoh.record.tools import check
from tests.integration.harness import ROOT, stop_run

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(420)]

_SOURCES = ("iw_zenoh", "agents", "bridges", "maps", "recordings", "pyproject.toml", "README.md")


def _install(tmp: Path) -> dict[str, str]:
    """Builds a wheel of a copy of the sources and installs it, without its dependencies (those
    of the test venv serve), into ``tmp/site``; the environment that imports it from there."""
    src = tmp / "src"
    for name in _SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.mcap"))
        else:
            shutil.copy(ROOT / name, src / name)
    shutil.copy(ROOT / "recordings" / "demo-sample.mcap", src / "recordings" / "demo-sample.mcap")
    pip = [sys.executable, "-m", "pip", "-q", "--disable-pip-version-check"]
    # built with the test venv's setuptools (the test extra has it): an isolated build env costs
    # a download and an install of setuptools each time (about a minute on a loaded 2-core CI)
    build = [*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", str(tmp / "dist"), str(src)]
    subprocess.run(build, check=True, timeout=300)
    [wheel] = (tmp / "dist").glob("iw_zenoh-*.whl")
    subprocess.run([*pip, "install", "--no-deps", "--target", str(tmp / "site"), str(wheel)], check=True, timeout=120)
    return {**os.environ, "PYTHONPATH": str(tmp / "site")}


def test_an_installed_package_lists_its_scenarios_and_runs_the_demo_by_name(tmp_path: Path) -> None:
    env = _install(tmp_path)
    here = tmp_path / "elsewhere"  # no checkout, no maps: only what the wheel installed
    here.mkdir()
    iwz = [sys.executable, "-m", "iw_zenoh.cli"]
    where = subprocess.run(
        [sys.executable, "-c", "import iw_zenoh; print(iw_zenoh.__file__)"],
        cwd=here,
        env=env,
        capture_output=True,
        text=True,
    )
    assert Path(where.stdout.strip()).is_relative_to(tmp_path / "site"), where  # the wheel, not the checkout
    listed = subprocess.run([*iwz, "scenarios"], cwd=here, env=env, capture_output=True, text=True, timeout=60)
    assert listed.returncode == 0, listed.stderr
    names = {line.split()[0] for line in listed.stdout.splitlines() if line and not line.startswith("run one")}
    assert names == {p.stem for p in (ROOT / "maps" / "scenarios").glob("*.toml")}
    assert str(tmp_path / "site") in listed.stdout
    sample = subprocess.run(
        [*iwz, "scenarios", "sample"], cwd=here, env=env, capture_output=True, text=True, timeout=60
    )
    assert Path(sample.stdout.strip()).is_file()

    # lock-step, so the verdict does not hang on how loaded the machine is; recorded where a user's
    # `iwz run demo` records: recordings/ in the folder it runs in
    # on a free port, not the default 7447: another run on this machine (a parallel test) may hold it
    argv = [
        *iwz,
        "run",
        "demo",
        "--lockstep",
        "--no-status",
        "--port",
        str(free_port()),
        "--log-dir",
        str(tmp_path / "logs"),
    ]
    p = subprocess.Popen(argv, cwd=here, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = p.communicate(timeout=240)
    except subprocess.TimeoutExpired:
        out, err = stop_run(p)
        pytest.fail(f"the demo still ran after 240 s, stopped:\n{out}{err}")
    assert p.returncode == 0, out + err
    assert "PASS robot 1 within 0.5 m of (20, 6.1)" in out
    [recording] = (here / "recordings").glob("demo-*.mcap")
    assert check(recording).whole
