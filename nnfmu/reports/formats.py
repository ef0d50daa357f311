"""How a number reads in a report: the filters every report template shares (`number`, `per_cent`, `p_value`)."""

from __future__ import annotations

import math

# Below this a double-precision p-value is rounding noise (1 - CDF loses everything under the machine epsilon, 2.2e-16),
# so it is shown as a bound, never as 0.
P_VALUE_FLOOR = 1e-16


def number(value: object, missing: str = "–") -> str:
    """A table cell: a number to 4 significant digits, `missing` for None, anything else as its text."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return f"{value:.4g}"
    return missing if value is None else str(value)


def per_cent(value: object) -> str:
    """A fraction as per cent for a `[%]` table cell (`0.02858` -> `2.858`), as headlines and the docs give errors;
    None as `–`."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return f"{100 * value:.4g}"
    return "–" if value is None else str(value)


def p_value_text(p: float | None) -> str:
    """A p-value for a report: `3.2e-05`, `< 1e-16` at the floating-point floor (a computed 0 included), `–` if none."""
    if p is None or not math.isfinite(p):
        return "–"
    return f"< {P_VALUE_FLOOR:g}" if p < P_VALUE_FLOOR else f"{p:.2g}"
