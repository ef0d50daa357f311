"""How numbers read in reports: a p-value below the floating-point floor as a bound, never as 0; a missing number as
the report chooses."""

from __future__ import annotations

from pathlib import Path

from nnfmu.reports.formats import number, p_value_text


def test_p_values_at_the_floor_read_as_a_bound() -> None:
    assert p_value_text(0.0) == "< 1e-16"
    assert p_value_text(3e-300) == "< 1e-16"
    assert p_value_text(3.2e-5) == "3.2e-05"
    assert p_value_text(None) == "–" and p_value_text(float("nan")) == "–"


def test_loop_reports_format_p_values_with_it() -> None:
    root = Path(__file__).resolve().parents[2] / "templates" / "reports"
    for template in ("loop.html.j2", "vehicle_loop.html.j2"):
        text = (root / template).read_text(encoding="utf-8")
        assert "p_value | p_value" in text and "p_value | number" not in text, template


def test_a_number_reads_to_four_digits_and_a_missing_one_as_asked() -> None:
    assert number(0.123456) == "0.1235" and number(3) == "3"
    assert number(None) == "–" and number(None, "n/a") == "n/a" and number(None, "") == ""
    assert number("gas_force") == "gas_force"
