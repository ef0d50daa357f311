"""The demo's and train's terminal tables fit an 80-column terminal without cutting a cell, errors in per cent."""

from __future__ import annotations

import io

from rich.console import Console

from nnfmu.workflows.demo import PRESETS_BY_RIG, ModelResult
from nnfmu.workflows.tables import component_table, loop_table, metrics_table, stage_table


def _render(table) -> str:
    text = io.StringIO()
    Console(file=text, width=80, markup=False).print(table)
    return text.getvalue()


def _model(preset: str) -> ModelResult:
    return ModelResult(
        preset,
        "x.onnx",
        "x.fmu",
        123.4,
        0.01234,
        0.0567,
        0.99876,
        -0.0345,
        1.0234,
        "x.html",
        (5, 6),
        "y.html",
        (17, 18),
    )


def test_component_table_fits_80_columns_with_every_cell_whole() -> None:
    presets = [p for group in PRESETS_BY_RIG.values() for p in group]
    text = _render(component_table([_model(p) for p in presets]))
    assert max(len(line) for line in text.splitlines()) <= 80
    assert "…" not in text
    for preset in presets:  # each name whole on one line
        assert any(preset in line for line in text.splitlines()), preset
    row = next(line for line in text.splitlines() if "damper-spline" in line).split()
    assert row[1:] == ["123.4", "1.23", "5.67", "0.9988", "-3.5", "1.023"]  # NRMSE and peak error in per cent


def test_metrics_loop_and_stage_tables_fit_80_columns() -> None:
    split = {
        "nrmse": 0.0106,
        "r2": 0.9991,
        "peak_error": 0.012,
        "slope": 0.998,
        "intercept": -1.5,
        "mse_scaled": 1.2e-5,
        "max_abs_weight": 17.8,
        "samples": 12000,
    }
    errors = {"nrmse": 0.0257, "r2": 0.998, "peak_error": -0.02, "pseudo_damage_ratio": 1.006}
    for table in (
        metrics_table({"train": split, "validation": split, "test": split}),
        loop_table(["temperature", "gas_force"], errors, {**errors, "nrmse": 0.0084}),
        stage_table({"component networks": 65.2, "vehicle-derived bushing networks": 12.0}, 77.2),
    ):
        text = _render(table)
        assert max(len(line) for line in text.splitlines()) <= 80 and "…" not in text
    rows = {line.split("  ")[0]: line.split()[-1] for line in _render(metrics_table({"test": split})).splitlines()}
    assert rows["NRMSE [%]"] == "1.06" and rows["max |error| [SI]"] == "0.012" and rows["samples"] == "12000"
    assert "2.57" in _render(loop_table([], errors, errors))
    assert "1 min 17 s" in _render(stage_table({"a": 77.2}, 77.2))


def test_report_channel_names_say_the_output_once() -> None:
    from nnfmu.workflows.demo import channel_label

    assert channel_label("bushing-axial-force", "axial_force") == "bushing_axial_force"
    assert channel_label("bushing-conical-torque", "conical_torque") == "bushing_conical_torque"
    assert channel_label("damper-spline", "force") == "damper_spline_force"
