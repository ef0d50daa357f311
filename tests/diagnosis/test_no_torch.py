"""The diagnosis library must work where torch cannot be imported at all, and must not reach the driver's stages."""

import subprocess
import sys

import pytest

# An import hook makes `import torch` (and fmpy) fail; then the library diagnoses a residual and extends a spec.
# (Not `sys.modules["torch"] = None`: scipy treats a present-but-None entry as an array library.)
SCRIPT = """
import sys

class Blocked:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("torch", "fmpy"):
            raise ImportError(name + " is blocked in this test")
        return None

sys.meta_path.insert(0, Blocked())
import numpy as np
from nnfmu.data import Measurement
from nnfmu.diagnosis import EFFECTS, DiagnosisSettings, Extension, diagnose
from nnfmu.models.features import FeatureSpec, Tap
import pytest

t = np.arange(4000) * 1e-3
v = np.cos(2 * np.pi * 2 * t)
m = Measurement(t, {"velocity": v, "displacement": np.sin(2 * np.pi * 2 * t) / (4 * np.pi),
                    "force": 3000 * v + 80 * np.tanh(v / 0.01)}, {"velocity": "m/s", "displacement": "m", "force": "N"})
predicted = 3000 * v + np.random.default_rng(0).normal(0, 1, len(t))
d = diagnose(m, predicted, "force", ["velocity"], DiagnosisSettings())
assert d.ranking[0].name == "seal_friction", d.summary
ext = EFFECTS["seal_friction"].extension(FeatureSpec((Tap("velocity"),), "force"), m, np.arange(len(t)),
                                         DiagnosisSettings())
assert isinstance(ext, Extension)
for stage in ("torch", "fmpy", "nnfmu.fmu", "nnfmu.cosim", "nnfmu.export", "nnfmu.workflows.loop",
              "nnfmu.models.train"):
    assert stage not in sys.modules, stage
"""


@pytest.mark.slow
def test_diagnose_and_extend_without_torch() -> None:
    run = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
