"""A port that is no TCP port is refused before a viewer joins the bus (no router is needed to
be told so)."""

from __future__ import annotations

import pytest

from iw_zenoh.cli import main as iwz


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["foxglove", "--port", "70000"], "iwz foxglove: --port 70000 is no TCP port: give 0..65535"),
        (["foxglove", "--port", "-1"], "iwz foxglove: --port -1 is no TCP port: give 0..65535"),
        (["view", "--port", "99999"], "iwz view: --port 99999 is no TCP port: give 0..65535"),
        (["view", "--foxglove-port", "70000"], "iwz view: --foxglove-port 70000 is no TCP port: give 0..65535"),
    ],
)
def test_a_port_out_of_range_is_a_usage_error_before_joining(
    argv: list[str], says: str, capfd: pytest.CaptureFixture[str]
) -> None:
    assert iwz([*argv, "--connect", "tcp/127.0.0.1:1"]) == 2  # nothing listens there: not reached
    out, err = capfd.readouterr()
    assert says in out + err
    assert "Traceback" not in out + err
    assert "cannot join the bus" not in out + err
