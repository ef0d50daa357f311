"""The component description in an ONNX file's metadata may come from anyone: whatever its JSON holds, building an
FMU from it ends in one error naming the field, never a traceback."""

from __future__ import annotations

import json
from pathlib import Path

import onnx
import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.component import METADATA_KEY
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.errors import FmuBuildError
from nnfmu.fmu.options import BuildOptions


def _meta() -> dict:
    model = linear_damper_graph(2400.0, name="damper")
    return json.loads(next(p.value for p in model.metadata_props if p.key == METADATA_KEY))


def _nested(depth: int) -> str:
    return "[" * depth + "1" + "]" * depth


META = _meta()
PORT = META["inputs"][0]
CASES = {
    "a JSON list": ("[1, 2]", r"the description is a JSON list, expected an object"),
    "nested arrays": (_nested(100_000), r"nested too deeply"),
    "nested objects": ('{"a":' * 100_000 + "1" + "}" * 100_000, r"nested too deeply"),
    "a number as name": (json.dumps(META | {"name": 5}), r"'name' is int 5, expected str"),
    "a string sample period": (json.dumps(META | {"sample_period": "0.001"}), r"sample period '0\.001' s must be"),
    "metadata as a list": (json.dumps(META | {"metadata": [1]}), r"'metadata' is list \[1\], expected dict"),
    "a number as unit": (json.dumps(META | {"inputs": [PORT | {"unit": 5}]}), r"input 0: 'unit' is int 5"),
    "a string envelope": (json.dumps(META | {"inputs": [PORT | {"min": "a"}]}), r"input 0: 'min' is str 'a'"),
    "a bool index": (json.dumps(META | {"outputs": [PORT | {"index": True}]}), r"output 0: 'index' is bool"),
    "a string version": (json.dumps(META | {"format_version": "2"}), r"'format_version' is str '2', expected int"),
    "a string state": (json.dumps(META | {"states": ["x"]}), r"state 0 is a JSON str, expected an object"),
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_a_malformed_description_is_refused_naming_the_field(tmp_path: Path, case: str) -> None:
    value, message = CASES[case]
    model = linear_damper_graph(2400.0, name="damper")
    next(p for p in model.metadata_props if p.key == METADATA_KEY).value = value
    onnx.save(model, tmp_path / "odd.onnx")
    with pytest.raises(FmuBuildError, match=rf"odd\.onnx: cannot read the component description: .*{message}"):
        build_fmu(tmp_path / "odd.onnx", BuildOptions(out=tmp_path / "odd.fmu"))
    assert not (tmp_path / "odd.fmu").exists()


def test_the_command_line_prints_one_error_line(tmp_path: Path) -> None:
    model = linear_damper_graph(2400.0, name="damper")
    next(p for p in model.metadata_props if p.key == METADATA_KEY).value = "[1, 2]"
    onnx.save(model, tmp_path / "odd.onnx")
    result = CliRunner().invoke(app, ["build", str(tmp_path / "odd.onnx"), "--out", str(tmp_path / "odd.fmu")])
    assert result.exit_code == 2 and result.output.startswith("error: "), result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)


def test_one_period_test_serves_records_and_models():
    from nnfmu.component import PERIOD_TOLERANCE, same_period

    assert same_period(1e-3, 1e-3 * (1 + 0.5 * PERIOD_TOLERANCE)) and same_period(1e-3 * (1 + 0.5e-6), 1e-3)
    assert not same_period(1e-3, 1e-3 * (1 + 2 * PERIOD_TOLERANCE))
    assert not same_period(1e-3, 1.0 / 1024)  # 1 kHz is not 1024 Hz
