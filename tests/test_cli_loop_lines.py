"""`nnfmu loop`'s before -> after lines give the NRMSE in per cent, as its headline and the docs do (issue 31: the
lines printed 0.02858 under a headline of 2.86 %)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest
from typer.testing import CliRunner

import nnfmu.workflows.loop.run as loop_run
from nnfmu.cli import app


def test_the_loop_lines_give_nrmse_in_per_cent(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    before = {"nrmse": 0.02858, "r2": 0.9991, "peak_error": 41.5, "pseudo_damage_ratio": 1.02}
    report = SimpleNamespace(
        summary="Force NRMSE on the held-out test part 2.86 % → 2.25 %",
        effects_added=["temperature"],
        error_before=before,
        error_after={**before, "nrmse": 0.02251, "pseudo_damage_ratio": None},
        notes=[],
        onnx=tmp_path / "m.onnx",
        fmu=tmp_path / "m.fmu",
    )
    monkeypatch.setattr(loop_run, "run_loop", lambda *args, **kwargs: report)
    (tmp_path / "dyno.csv").write_text("time [s],velocity [m/s],force [N]\n0,0,0\n", encoding="utf-8")
    result = CliRunner().invoke(
        app, ["loop", str(tmp_path / "dyno.csv"), "--model", "m.onnx", "--output", "force", "--out", str(tmp_path)]
    )
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert "  NRMSE [%]: 2.858 -> 2.251" in lines
    assert "  pseudo-damage ratio: 1.02 -> not meaningful" in lines
    assert "0.02858" not in result.output
