"""`nnfmu cosim --engine compiled`: the system run as its cached system FMU, stepped from C, gives the Python
engine's result (channels, units, time axis, values within 1e-12 of each channel's peak) for every one-pass scheme,
and refuses what its system FMU cannot do.

The fixture is the container tests' quarter car (the vehicle package's quarter car sampled at the step, with a linear
damper FMU of 2400 N.s/m) on their test drive.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import onnx
import pytest
from typer.testing import CliRunner

sys.path.insert(0, str(Path(__file__).parents[1] / "cosim"))  # the master's test drive
from cosim_system_helpers import drive  # noqa: E402

from nnfmu.cli import app  # noqa: E402
from nnfmu.cosim.master import CosimSettings, CosimWarning  # noqa: E402
from nnfmu.cosim.settings import CosimError  # noqa: E402
from nnfmu.cosim.ssp import connect_by_name, write_ssd  # noqa: E402
from nnfmu.data import load_measurement  # noqa: E402
from nnfmu.data.drive_files import write_drive  # noqa: E402
from nnfmu.errors import SettingsError  # noqa: E402
from nnfmu.export.linear_damper import linear_damper_graph  # noqa: E402
from nnfmu.fmu.build import build_fmu  # noqa: E402
from nnfmu.fmu.options import BuildOptions  # noqa: E402
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu  # noqa: E402
from nnfmu.workflows.cosim import run_cosim  # noqa: E402

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")

H = 1e-3  # [s]
DURATION = 0.3  # [s]
TOLERANCE = 1e-12  # relative to each channel's peak
SCHEMES = [{}, {"scheme": "jacobi"}, {"order": "components-first", "refresh": False}]


@pytest.fixture(scope="module")
def quarter_car(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(the system's .ssd, the drive file)."""
    folder = tmp_path_factory.mktemp("compiled_engine")
    onnx.save(linear_damper_graph(2400.0), folder / "damper.onnx")
    damper = build_fmu(folder / "damper.onnx", BuildOptions(out=folder / "damper.fmu"))
    vehicle = build_vehicle_fmu("quarter-car", folder / "car.fmu", VehicleBuildSettings(sample_period=H))
    system = connect_by_name("quarter car", ("vehicle", vehicle), {"damper": damper}, folder)
    ssd = write_ssd(system, folder / "SystemStructure.ssd")
    return ssd, write_drive(drive(DURATION, H, corner="fl"), folder / "drive.csv")


def largest_difference(result, reference) -> float:  # noqa: ANN001 (Measurements)
    return max(float(np.max(np.abs(result[c] - reference[c])) / np.max(np.abs(reference[c]))) for c in reference.names)


@pytest.mark.slow
@pytest.mark.parametrize("scheme", SCHEMES, ids=lambda s: ",".join(f"{k}={v}" for k, v in s.items()) or "default")
def test_the_compiled_engine_gives_the_python_engines_result(quarter_car: tuple[Path, Path], scheme: dict) -> None:
    ssd, drive_file = quarter_car
    settings = CosimSettings(step=H, **scheme)
    python = run_cosim(ssd, drive_file, settings)
    compiled = run_cosim(ssd, drive_file, settings, engine="compiled")
    assert compiled.master == "compiled" and compiled.measurement.notes["engine"] == "compiled"
    assert python.master == "fmpy"
    reference, result = python.measurement, compiled.measurement
    assert result.names == reference.names and result.units == reference.units
    np.testing.assert_array_equal(result.time, reference.time)
    assert compiled.steps == python.steps == round(DURATION / H)
    assert largest_difference(result, reference) <= TOLERANCE
    assert np.ptp(result["damper_force"]) > 100.0  # [N] the damper did work: the comparison means something


@pytest.mark.slow
def test_a_system_is_built_once_and_rebuilt_when_it_changes(
    quarter_car: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The second run of the same system and settings reuses the cached system FMU; another scheme builds another."""
    monkeypatch.setenv("NNFMU_CACHE", str(tmp_path / "cache"))
    ssd, drive_file = quarter_car
    settings = CosimSettings(step=H, stop_time=0.05)
    runs = [run_cosim(ssd, drive_file, settings, engine="compiled") for _ in range(2)]
    other = run_cosim(ssd, drive_file, CosimSettings(step=H, stop_time=0.05, scheme="jacobi"), engine="compiled")
    assert [r.measurement.notes["built"] for r in (*runs, other)] == ["True", "False", "True"]
    assert len(list((tmp_path / "cache" / "system-fmus").iterdir())) == 2
    np.testing.assert_array_equal(runs[0].measurement["damper_force"], runs[1].measurement["damper_force"])


@pytest.mark.slow
def test_the_training_envelope_warning_comes_as_from_the_python_engine(
    quarter_car: tuple[Path, Path], tmp_path: Path
) -> None:
    """A damper network driven past its training envelope: the compiled engine's run gives run_cosim's warning, word
    for word as the Python engine's (downstream of the result, nothing differs)."""
    ssd, drive_file = quarter_car
    shutil.copyfile(ssd.parent / "car.fmu", tmp_path / "car.fmu")
    onnx.save(linear_damper_graph(2400.0, velocity_range=(-0.05, 0.05)), tmp_path / "narrow.onnx")
    damper = build_fmu(tmp_path / "narrow.onnx", BuildOptions(out=tmp_path / "narrow.fmu"))
    system = connect_by_name("quarter car", ("vehicle", tmp_path / "car.fmu"), {"damper": damper}, tmp_path)
    narrow = write_ssd(system, tmp_path / "SystemStructure.ssd")
    said = {}
    for engine in ("python", "compiled"):
        with pytest.warns(CosimWarning) as caught:
            run_cosim(narrow, drive_file, CosimSettings(step=H), engine=engine)
        said[engine] = [str(w.message) for w in caught if "training envelope" in str(w.message)]
    assert len(said["compiled"]) == 1 and "element 'damper': input 'velocity' reached" in said["compiled"][0]
    assert said["compiled"] == said["python"]


@pytest.mark.slow
def test_a_part_failing_inside_is_a_cosim_error_naming_it(quarter_car: tuple[Path, Path], tmp_path: Path) -> None:
    """The damper's output gain at 1e308 (set by the SSD): its force overflows, the car refuses the slope of its
    damper-force input inside the system FMU, and the run ends in a CosimError naming the time, the failed call and,
    from the system FMU's log, the element and its input."""
    ssd, drive_file = quarter_car
    for name in ("car.fmu", "damper.fmu"):
        shutil.copyfile(ssd.parent / name, tmp_path / name)
    system = connect_by_name(
        "quarter car",
        ("vehicle", tmp_path / "car.fmu"),
        {"damper": tmp_path / "damper.fmu"},
        tmp_path,
        parameters={"damper": {"output_gain": 1e308}},
    )
    wild = write_ssd(system, tmp_path / "SystemStructure.ssd")
    with pytest.raises(CosimError) as caught:
        run_cosim(wild, drive_file, CosimSettings(step=H), engine="compiled")
    message = str(caught.value)
    assert "(compiled engine), step from t = " in message and "doStep failed with status 3" in message, message
    assert "element 'vehicle'" in message and "input 'damper_force'" in message, message


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"iterations": 2}, "one-pass schemes only .*iterations 2"),
        ({"extrapolation": "none"}, "one-pass schemes only .*extrapolation 'none'"),
        ({"inner_loop": "python"}, "inner_loop 'python'"),
    ],
)
def test_settings_the_system_fmu_cannot_step_are_refused(
    quarter_car: tuple[Path, Path], settings: dict, message: str
) -> None:
    ssd, drive_file = quarter_car
    with pytest.raises(CosimError, match=message):
        run_cosim(ssd, drive_file, CosimSettings(step=H, **settings), engine="compiled")


def test_another_master_or_engine_is_refused(quarter_car: tuple[Path, Path]) -> None:
    ssd, drive_file = quarter_car
    with pytest.raises(SettingsError, match="compiled engine runs nnfmu's own coupling .*'libcosim'"):
        run_cosim(ssd, drive_file, CosimSettings(step=H), master="libcosim", engine="compiled")
    with pytest.raises(SettingsError, match="unknown engine 'fast'; use python or compiled"):
        run_cosim(ssd, drive_file, CosimSettings(step=H), engine="fast")


def test_the_cli_runs_the_compiled_engine_and_refuses_what_it_cannot(
    quarter_car: tuple[Path, Path], tmp_path: Path
) -> None:
    ssd, drive_file = quarter_car
    runner = CliRunner()
    out = tmp_path / "result.csv"
    done = runner.invoke(app, ["cosim", str(ssd), "--drive", str(drive_file), "-o", str(out), "--engine", "compiled"])
    assert done.exit_code == 0, done.output
    reference = run_cosim(ssd, drive_file, CosimSettings(step=H)).measurement
    result = load_measurement(out)  # the loader adds derived rates: compare the written channels
    assert set(reference.names) <= set(result.names) and largest_difference(result, reference) <= TOLERANCE
    refused = runner.invoke(
        app, ["cosim", str(ssd), "--drive", str(drive_file), "-o", str(tmp_path / "r2.csv"), "--engine", "compiled",
              "--iterations", "2"]
    )  # fmt: skip
    assert refused.exit_code == 2 and "error: the compiled engine steps nnfmu's one-pass schemes only" in refused.output
    study = runner.invoke(
        app, ["cosim", str(ssd), "--drive", str(drive_file), "-o", str(tmp_path / "r3.csv"), "--engine", "compiled",
              "--step-study"]
    )  # fmt: skip
    assert study.exit_code == 2 and "--step-study runs on --master fmpy --engine python" in study.output
    assert not (tmp_path / "r2.csv").exists() and not (tmp_path / "r3.csv").exists()


@pytest.mark.slow
def test_the_cosim_workflow_loads_no_torch() -> None:
    """`nnfmu cosim` (either engine) checks the training envelope through `workflows.roadtest`, whose package must not
    bring the training side (torch) with it: that import cost a 2 s full-vehicle run 4 s of CPU."""
    import subprocess

    script = "import sys, nnfmu.workflows.cosim; print('torch' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"


SANITIZED_CC = "gcc -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -g"
RUN_COMPILED = """
import sys
from nnfmu.cosim.master import CosimSettings
from nnfmu.workflows.cosim import run_cosim
result = run_cosim(sys.argv[1], sys.argv[2], CosimSettings(step=float(sys.argv[3])), engine="compiled")
print("steps", result.steps)
"""


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc (with its ASan and UBSan runtimes) is not installed")
def test_the_engines_c_loop_and_system_fmu_run_clean_under_asan_and_ubsan(
    quarter_car: tuple[Path, Path], tmp_path: Path
) -> None:
    """system_loop.c and the system FMU it steps, both compiled with ASan and UBSan (`CC`, a fresh cache), run the
    quarter car in a Python whose process loads the ASan runtime first: no sanitizer report, every step taken."""
    import os
    import subprocess

    ssd, drive_file = quarter_car

    def runtime(name: str) -> str:
        return subprocess.run(["gcc", f"-print-file-name={name}"], capture_output=True, text=True).stdout.strip()

    environment = {
        **os.environ,
        "CC": SANITIZED_CC,
        "NNFMU_CACHE": str(tmp_path / "cache"),
        # libstdc++ beside it: ASan intercepts C++ throws, which the interpreter's extension modules make
        "LD_PRELOAD": f"{runtime('libasan.so')} {runtime('libstdc++.so')}",
        "ASAN_OPTIONS": "detect_leaks=0",  # the interpreter's own allocations outlive the run by design
        "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[2]), os.environ.get("PYTHONPATH", "")]),
    }
    command = [sys.executable, "-c", RUN_COMPILED, str(ssd), str(drive_file), str(H)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600, env=environment)
    assert result.returncode == 0, result.stderr[-4000:]
    assert f"steps {round(DURATION / H)}" in result.stdout
    assert "AddressSanitizer" not in result.stderr and "runtime error" not in result.stderr, result.stderr[-4000:]
