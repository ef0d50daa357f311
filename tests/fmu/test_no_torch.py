"""Building and running an FMU must work where torch cannot be imported at all."""

import subprocess
import sys
from pathlib import Path

import onnx
import pytest
from native_fmu_helpers import delay_step_graph

# An import hook makes `import torch` fail; then the FMU is built through the CLI and replayed: any torch import on
# the way raises. (Not `sys.modules["torch"] = None`: scipy treats a present-but-None entry as an array library.)
SCRIPT = """
import sys

class NoTorch:
    def find_spec(self, name, path=None, target=None):
        if name == "torch" or name.startswith("torch."):
            raise ImportError("torch is blocked in this test")
        return None

sys.meta_path.insert(0, NoTorch())
import numpy as np
from typer.testing import CliRunner
from nnfmu.cli import app
from nnfmu.cosim.replay import replay_fmu
from nnfmu.data.measurement import Measurement
result = CliRunner().invoke(app, ["build", sys.argv[1], "--out", sys.argv[2]])
assert result.exit_code == 0, result.output
t = np.arange(50) * 1e-3
m = Measurement(t, {"velocity": np.sin(t), "displacement": np.cos(t)}, {"velocity": "m/s", "displacement": "m"})
out = replay_fmu(sys.argv[2], m)
assert np.all(np.isfinite(out["force"]))
assert "torch" not in sys.modules
"""


@pytest.mark.slow
def test_build_and_replay_without_torch(tmp_path: Path) -> None:
    onnx_path = tmp_path / "damper.onnx"
    onnx.save(delay_step_graph(), onnx_path)
    run = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(onnx_path), str(tmp_path / "damper.fmu")], capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "damper.fmu").exists()
