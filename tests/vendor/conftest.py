"""Fixtures of the vendor-vehicle tests: the vendor quarter car + nnfmu damper system, built once per session."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the test modules import vendor_system beside this file
from vendor_system import write_road, write_vendor_system  # noqa: E402


@pytest.fixture(scope="session")
def vendor(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(SystemStructure.ssd of the vendor quarter car with an nnfmu damper, a 0.5 s road drive CSV)."""
    folder = tmp_path_factory.mktemp("vendor")
    return write_vendor_system(folder), write_road(folder / "road.csv", 0.5)
