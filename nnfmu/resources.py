"""Locate files that ship with nnfmu (the FMI templates) in a wheel or in a source checkout."""

from __future__ import annotations

from pathlib import Path


def templates_dir() -> Path:
    """The `templates/` folder: `nnfmu/templates` inside an installed wheel, else the repository's top-level one."""
    packaged = Path(__file__).resolve().parent / "templates"
    if packaged.is_dir():
        return packaged
    checkout = Path(__file__).resolve().parent.parent / "templates"
    if checkout.is_dir():
        return checkout
    raise FileNotFoundError(f"nnfmu templates not found in {packaged} or {checkout}")
