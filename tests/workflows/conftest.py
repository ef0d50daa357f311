"""The workflow tests (the loop's, the characterisation's) import the plain fmpy replay of the co-simulation tests
(tests/cosim/plain_master.py)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[1] / "cosim"))
