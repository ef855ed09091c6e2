"""The ros2-demo scenario reads, and ``iwz run`` plans its ``ros2`` agent as ``iwz ros2`` with the
``[ros2]`` table's domain, namespace and command type (an agent all the same: started last, its
robots its own when secured); ``iwz ros2`` refuses a bad domain or namespace with the reason."""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest

from iw_zenoh.errors import ConfigError
from iw_zenoh.launch.launcher import Launcher
from iw_zenoh.launch.launcher import main as run_main
from iw_zenoh.launch.secure_run import agent_robots
from iw_zenoh.nodes import ros2
from iw_zenoh.scenario.file import load_scenario
from iw_zenoh.scenario.tables import Ros2Section

MAPS = Path(__file__).resolve().parents[2] / "maps"


def test_the_demo_plans_iwz_ros2_with_its_ros2_table(tmp_path: Path) -> None:
    sc = load_scenario(MAPS / "scenarios" / "ros2-demo.toml")
    assert sc.ros2 == Ros2Section(domain_id=0, namespace="/robot{id}", stamped=False)
    (agent,) = sc.agents
    assert agent.program == "ros2"
    assert isinstance(agent.spec, dict)
    assert agent.spec["lasers"][0]["beams"] == 271
    sc = msgspec.structs.replace(sc, ros2=Ros2Section(domain_id=7, namespace="/chair_{id}", stamped=True))
    launcher = Launcher(sc, port=7447, log_dir=tmp_path, status=False, record=None)
    launcher.plan()
    (c,) = [c for c in launcher.children if c.name == "agent-1-ros2"]
    assert c.role == "agent"
    cmd = c.argv[c.argv.index("iw_zenoh.cli") + 1 :]
    assert cmd[0] == "ros2"
    assert cmd[cmd.index("--domain") + 1] == "7"
    assert cmd[cmd.index("--namespace") + 1] == "/chair_{id}"
    assert "--stamped" in cmd
    assert cmd[cmd.index("--id") + 1] == "1"
    assert agent_robots(sc) == {"agent-1-ros2": (1,)}


@pytest.mark.parametrize(
    ("argv", "why"),
    [
        (["--domain", "233"], "ROS_DOMAIN_ID"),
        (["--domain", "-1"], "ROS_DOMAIN_ID"),
        (["--robots", "2", "--namespace", "/one"], "{id}"),
        (["--robots", "0"], "--robots"),
    ],
)
def test_iwz_ros2_refuses_bad_arguments_with_the_reason(
    argv: list[str], why: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert ros2.main([*argv, "-e", "tcp/127.0.0.1:1"]) == 2
    assert why in capsys.readouterr().out


def test_the_scenario_refuses_a_bad_domain(tmp_path: Path) -> None:
    (tmp_path / "lab.xml").write_text('<Lab Name="l" Width="5" Height="5"/>')
    bad = tmp_path / "s.toml"
    bad.write_text('[world]\nmap = "lab.xml"\n[ros2]\ndomain_id = 300\n')
    with pytest.raises(Exception, match="domain_id"):
        load_scenario(bad)


def test_a_secured_run_with_iwz_ros2_is_refused_before_anything_starts_saying_why(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the policy grants our roles only: its odom, /tf, /clock, tokens and cmd_vel would all be
    # dropped by the router without a word, the chair never driven
    demo = str(MAPS / "scenarios" / "ros2-demo.toml")
    assert run_main([demo, "--secure", "--no-status", "--no-record", "--log-dir", str(tmp_path)]) == 2
    out = capsys.readouterr().out
    assert "agent-1-ros2 is `iwz ros2`, which a secured run cannot serve" in out
    assert "grants no ROS 2 keys" in out
    assert not (tmp_path / "ids").exists()  # nothing issued, nothing started
    with pytest.raises(ConfigError, match="without --secure"):
        Launcher(load_scenario(demo), port=7447, log_dir=tmp_path, status=False, secure=True)
