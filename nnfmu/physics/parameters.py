"""Physical parameters with units: a dataclass field helper and a plain description for the truth file."""

from __future__ import annotations

import dataclasses
from typing import Any


def param(default: float, unit: str, doc: str) -> Any:
    """A dataclass field holding a physical parameter with its SI unit and a short meaning."""
    return dataclasses.field(default=default, metadata={"unit": unit, "doc": doc})


def describe(params: Any) -> dict[str, Any]:
    """Every field of a parameter dataclass as {name: {value, unit, doc}}; nested parameter dataclasses recurse."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        if dataclasses.is_dataclass(value):
            out[f.name] = describe(value)
        else:
            out[f.name] = {"value": value, "unit": f.metadata.get("unit", ""), "doc": f.metadata.get("doc", "")}
    return out
