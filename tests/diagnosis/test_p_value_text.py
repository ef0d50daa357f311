"""Reports give a p-value below the floating-point floor as a bound, never as 0."""

from __future__ import annotations

from pathlib import Path

from nnfmu.diagnosis.evidence import p_value_text


def test_p_values_at_the_floor_read_as_a_bound() -> None:
    assert p_value_text(0.0) == "< 1e-16"
    assert p_value_text(3e-300) == "< 1e-16"
    assert p_value_text(3.2e-5) == "3.2e-05"
    assert p_value_text(None) == "–" and p_value_text(float("nan")) == "–"


def test_loop_reports_format_p_values_with_it() -> None:
    root = Path(__file__).resolve().parents[2] / "nnfmu" / "workflows"
    for template in ("loop/loop_report.html.j2", "vehicle_loop/vehicle_report.html.j2"):
        text = (root / template).read_text(encoding="utf-8")
        assert "p_value | p_value" in text and "p_value | number" not in text, template
