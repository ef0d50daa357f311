"""Fixtures of the co-simulation tests: the hand-made quarter car + damper system for several steps (built once)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the test modules import cosim_system_helpers beside this file
from cosim_system_helpers import build, damper_graph, write_system  # noqa: E402

STEPS = (0.5e-3, 1e-3, 2e-3)


@pytest.fixture(scope="session")
def systems(tmp_path_factory: pytest.TempPathFactory) -> dict[float, Path]:
    """SystemStructure.ssd of the quarter car + damper for each communication step in STEPS, by step."""
    base = tmp_path_factory.mktemp("cosim")
    damper = build(damper_graph(), base / "components", "damper")
    return {h: write_system(base / f"step_{round(h * 1e6)}us", h, damper) for h in STEPS}
