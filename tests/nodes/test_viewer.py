"""``iwz view`` refuses what it cannot do before joining any network, saying how to fix it."""

from __future__ import annotations

from pathlib import Path

import pytest

from iw_zenoh.nodes.viewer import main


def test_a_missing_recording_is_refused_naming_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(tmp_path / "gone.mcap")]) == 2
    out = capsys.readouterr().out
    assert "gone.mcap: no such file" in out
    assert "give an MCAP recording" in out


def test_a_port_out_of_range_is_refused_saying_which_are_ports(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--port", "70000"]) == 2
    assert "give 0..65535 (0: any free port)" in capsys.readouterr().out


def test_help_teaches_with_examples(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "iwz view recordings/demo-sample.mcap" in out
    assert "--port 0" in out
