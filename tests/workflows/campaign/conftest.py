"""Fixtures of the campaign tests: a quarter car with linear damper FMUs (one stable reference, one firmer, one so
stiff that the explicit coupling diverges) and a writer of small campaign files."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the test modules import campaign_helpers beside this file
from campaign_helpers import DAMPERS  # noqa: E402

from nnfmu.workflows.campaign.quarter_car import build_quarter_car_system  # noqa: E402


@pytest.fixture(scope="session")
def quarter_car(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Paths of the quarter-car system and its damper FMUs ('system', 'vehicle', and each name in DAMPERS)."""
    return build_quarter_car_system(tmp_path_factory.mktemp("quarter-car"), DAMPERS)
