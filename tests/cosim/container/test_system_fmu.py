"""The system FMU (`nnfmu system build`) in a plain FMI 2 loop against nnfmu's Python master on the same system.

The quarter car of the vehicle package (interpolates its inputs, feedthrough: slopes and the refresh) with a linear
damper FMU. The loop sets the system FMU's drive inputs at t_n and their slopes over the step (the drive is linear
between its samples, as the master interpolates it), so the C master inside sees what the Python master sees: at the
outer step H = h the two must agree to rounding on every output, and with H = 4 h the system FMU must reproduce the
master's run at h (sub-stepping), not its run at H.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import onnx
import pytest
from cosim_system_helpers import drive
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from nnfmu.cosim.container.build import build_system_fmu
from nnfmu.cosim.master import CosimError, CosimSettings, CosimWarning, cosimulate
from nnfmu.cosim.slave import FmuSlave
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")

H = 1e-3  # [s] the outer step
DURATION = 0.3  # [s]
TOLERANCE = 1e-12  # relative to each output's peak
NO_DERIVATIVES = {"port_derivatives": False}


def quarter_car(folder: Path, sample_period: float, fmi: int = 2) -> Path:
    """The quarter car (fl corner, sampling at `sample_period` [s]) with a linear damper FMU of 2400 N.s/m, both
    FMUs of FMI version `fmi`."""
    folder.mkdir(parents=True, exist_ok=True)
    onnx.save(linear_damper_graph(2400.0), folder / "damper.onnx")
    damper = build_fmu(folder / "damper.onnx", BuildOptions(out=folder / "damper.fmu", fmi_version=fmi))
    settings = VehicleBuildSettings(sample_period=sample_period, fmi_version=fmi)
    vehicle = build_vehicle_fmu("quarter-car", folder / "car.fmu", settings)
    return write_ssd(
        connect_by_name("quarter car", ("vehicle", vehicle), {"damper": damper}, folder), folder / "system.ssd"
    )


@pytest.fixture(scope="module")
def at_h(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return quarter_car(tmp_path_factory.mktemp("system_h"), H)


@pytest.fixture(scope="module")
def at_h_fmi3(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return quarter_car(tmp_path_factory.mktemp("system_h_fmi3"), H, fmi=3)


@pytest.fixture(scope="module")
def at_quarter_h(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return quarter_car(tmp_path_factory.mktemp("system_h4"), H / 4)


def build(
    ssd: Path, out: Path, inner_step: float | None = None, fmi: int = 2, extrapolate: bool = True, **settings: object
) -> Path:
    with open_system(ssd) as system:
        coupling = CosimSettings(**NO_DERIVATIVES, **settings)
        build_system_fmu(system, out, H, inner_step, coupling, fmi=fmi, extrapolate_drive=extrapolate)
    return out


def master(ssd: Path, step: float, **settings: object) -> dict[str, np.ndarray]:
    with open_system(ssd) as system:
        result = cosimulate(
            system, drive(DURATION, H, corner="fl"), CosimSettings(step=step, **NO_DERIVATIVES, **settings)
        )
    return {name: result.measurement[name] for name in result.measurement.names}


def run(fmu: Path, slopes: bool = True, drive_scale: float = 1.0) -> tuple[dict[str, np.ndarray], FmuSlave]:
    """The system FMU in a fixed-step loop at H on the test drive (sampled at H): inputs at t_n, with `slopes` their
    slopes over the step; outputs at t_0 .. t_N. Returns the outputs and the (closed) slave, for its messages."""
    slave = FmuSlave(fmu, instance_name="car")
    inputs, outputs = slave.names("input"), slave.names("output")
    source = drive(DURATION, H, corner="fl")
    u = np.column_stack([source[name] for name in inputs]) * drive_scale
    rows = []
    try:
        slave.enter_initialization(0.0)
        slave.set_real(inputs, u[0])
        slave.exit_initialization()
        rows.append(slave.get_real(outputs))
        references = slave.value_references(inputs)
        for n in range(len(u) - 1):
            slave.set_real(inputs, u[n])
            if slopes:
                slave.fmu.setRealInputDerivatives(references, [1] * len(inputs), list((u[n + 1] - u[n]) / H))
            slave.do_step(n * H, H)
            rows.append(slave.get_real(outputs))
    finally:
        slave.close()
    table = np.array(rows)
    return {name: table[:, i] for i, name in enumerate(outputs)}, slave


def worst(result: dict[str, np.ndarray], reference: dict[str, np.ndarray], stride: int = 1) -> dict[str, float]:
    """Per output: the largest difference relative to the reference's peak (reference sampled every `stride`)."""
    return {
        name: float(np.max(np.abs(values - reference[name][::stride])) / np.max(np.abs(reference[name][::stride])))
        for name, values in result.items()
    }


SCHEMES = [{}, {"scheme": "jacobi"}, {"order": "components-first", "refresh": False}]


@pytest.mark.slow
@pytest.mark.parametrize("settings", SCHEMES, ids=lambda s: ",".join(f"{k}={v}" for k, v in s.items()) or "default")
def test_the_system_fmu_gives_the_masters_numbers_at_its_step(at_h: Path, tmp_path: Path, settings: dict) -> None:
    result, _ = run(build(at_h, tmp_path / "car.fmu", **settings))
    reference = master(at_h, H, **settings)
    assert set(result) == set(reference)
    errors = worst(result, reference)
    assert max(errors.values()) <= TOLERANCE, errors
    assert np.ptp(result["damper_force"]) > 100.0  # [N] the damper did work: the comparison means something


@pytest.mark.slow
def test_fmi3_parts_are_stepped_as_the_master_steps_them(at_h_fmi3: Path, tmp_path: Path) -> None:
    """The quarter car and damper as FMI 3 FMUs inside the FMI 2 system FMU: the master's numbers at its step (the
    FMI 3 car holds its inputs over the step in both, as the master warns)."""
    ssd = at_h_fmi3
    result, _ = run(build(ssd, tmp_path / "car.fmu"))
    with pytest.warns(CosimWarning, match="FMI 3: no input derivatives"):
        reference = master(ssd, H)
    errors = worst(result, reference)
    assert max(errors.values()) <= TOLERANCE, errors
    assert np.ptp(result["damper_force"]) > 100.0


@pytest.mark.slow
def test_the_system_fmu_sub_steps_as_the_master_at_the_inner_step(at_quarter_h: Path, tmp_path: Path) -> None:
    """H = 4 h: the master's run at h, every fourth sample, to rounding; the master's run at H differs by far more."""
    result, _ = run(build(at_quarter_h, tmp_path / "car.fmu", inner_step=H / 4))
    fine, coarse = master(at_quarter_h, H / 4), master(at_quarter_h, H)
    assert max(worst(result, fine, stride=4).values()) <= TOLERANCE
    assert worst(result, coarse)["damper_force"] > 1e-4  # sub-stepping changed the result measurably


@pytest.mark.slow
def test_without_input_derivatives_the_drive_is_extrapolated_from_the_step_before(
    at_quarter_h: Path, tmp_path: Path
) -> None:
    """A plain loop at H = 4 h that sets no input derivatives: the drive extrapolated over each step from its slope
    over the step before comes at least five times closer to the master's run at h than the drive held (measured at
    1 s: 0.15 % against 2.4 % of the damper force's peak at H = 10 h)."""
    fine = master(at_quarter_h, H / 4)
    extrapolated, _ = run(build(at_quarter_h, tmp_path / "on.fmu", inner_step=H / 4), slopes=False)
    held, _ = run(build(at_quarter_h, tmp_path / "off.fmu", inner_step=H / 4, extrapolate=False), slopes=False)
    errors = {
        name: worst(result, fine, stride=4)["damper_force"] for name, result in (("on", extrapolated), ("off", held))
    }
    assert errors["on"] * 5 < errors["off"], errors


def test_the_system_fmu_validates_and_runs_in_fmpys_own_loop(at_h: Path, tmp_path: Path) -> None:
    """fmpy's validation finds no problem; fmpy's simulate_fmu (no input derivatives: the drive extrapolated)
    runs it and the damper moves."""
    from fmpy import simulate_fmu

    fmu = build(at_h, tmp_path / "car.fmu")
    assert validate_fmu(str(fmu)) == []
    source = drive(DURATION, H, corner="fl")
    signals = np.array(
        list(zip(source.time, source["actuator_fl_displacement"], source["actuator_fl_velocity"])),
        dtype=[("time", float), ("actuator_fl_displacement", float), ("actuator_fl_velocity", float)],
    )
    result = simulate_fmu(str(fmu), stop_time=DURATION, output_interval=H, input=signals, output=["damper_force"])
    assert np.all(np.isfinite(result["damper_force"])) and np.ptp(result["damper_force"]) > 100.0


@pytest.mark.slow
def test_an_fmi3_system_fmu_validates_and_steps_as_the_fmi2_one_without_slopes(at_h: Path, tmp_path: Path) -> None:
    """`--fmi 3`: fmpy's validation finds no problem; FMI 3 co-simulation has no input derivatives, so it always
    extrapolates the drive from the step before, and gives the FMI 2 system FMU's numbers when that is given no
    slopes either."""
    fmu3 = build(at_h, tmp_path / "car3.fmu", fmi=3)
    assert validate_fmu(str(fmu3)) == []
    result, _ = run(fmu3, slopes=False)
    reference, _ = run(build(at_h, tmp_path / "car2.fmu"), slopes=False)
    errors = worst(result, reference)
    assert max(errors.values()) <= TOLERANCE, errors
    assert np.ptp(result["damper_force"]) > 100.0


def test_a_parts_failure_is_the_system_fmus_error_naming_the_element(at_h: Path, tmp_path: Path) -> None:
    """A drive that overflows the car's motion: the car finds its acceleration infinite and refuses, the system FMU
    returns an error status and its log names the element, the call and the time; the part's own message comes with
    its name."""
    slave = FmuSlave(build(at_h, tmp_path / "car.fmu"), instance_name="car")
    try:
        slave.enter_initialization(0.0)
        slave.exit_initialization()
        slave.set_real(["actuator_fl_displacement", "actuator_fl_velocity"], [1e306, 1e306])
        with pytest.raises(FMICallException, match="fmi2DoStep failed with status 3"):
            for n in range(100):
                slave.do_step(n * H, H)
        errors = [message for status, _, message in slave.messages if status >= 3]
        assert any(m.startswith("element 'vehicle': output 'spindle_acceleration'") for m in errors), errors
        assert (
            "element 'vehicle' (fmus/0): refresh: get outputs failed with status 3 in the inner step from t = 0 s "
            "(h = 0.001 s)" in errors
        ), errors
        with pytest.raises(FMICallException):  # a failed system FMU steps no more
            slave.do_step(n * H, H)
    finally:
        slave.close()


def test_a_step_off_the_inner_grid_is_refused_with_the_reason(at_quarter_h: Path, tmp_path: Path) -> None:
    fmu = build(at_quarter_h, tmp_path / "car.fmu", inner_step=H / 4)
    slave = FmuSlave(fmu, instance_name="car")
    try:
        slave.enter_initialization(0.0)
        slave.exit_initialization()
        with pytest.raises(FMICallException):
            slave.do_step(0.0, H / 3)
        assert any("is not a whole number of the system's inner steps" in m for _, _, m in slave.messages)
    finally:
        slave.close()


def test_an_inner_step_the_vehicle_cannot_honour_is_refused_at_build(at_h: Path, tmp_path: Path) -> None:
    """The car samples every H and has feedthrough: an inner step of H/2 is refused before anything is compiled."""
    with pytest.raises(CosimError, match="whole multiple of 0.001 s"):
        with open_system(at_h) as system:
            build_system_fmu(system, tmp_path / "car.fmu", H, H / 2, CosimSettings(**NO_DERIVATIVES))
    assert not (tmp_path / "car.fmu").exists()


def test_parameters_reach_the_part_by_element_name(at_h: Path, tmp_path: Path) -> None:
    """`damper.output_gain` = 0 on the system FMU: the damper's force is zero throughout."""
    fmu = build(at_h, tmp_path / "car.fmu")
    slave = FmuSlave(fmu, instance_name="car")
    try:
        slave.set_real(["damper.output_gain"], [0.0])
        slave.enter_initialization(0.0)
        slave.exit_initialization()
        slave.set_real(["actuator_fl_displacement", "actuator_fl_velocity"], [0.01, 0.1])
        for n in range(20):
            slave.do_step(n * H, H)
        assert slave.get_real(["damper_force"])[0] == 0.0
        assert slave.get_real(["damper.output_gain"])[0] == 0.0
        assert slave.get_real(["spindle_displacement"])[0] != 0.0  # the car moved
    finally:
        slave.close()


@pytest.mark.slow
def test_the_cli_builds_one(at_h: Path, tmp_path: Path) -> None:
    out = tmp_path / "cli.fmu"
    done = subprocess.run(
        [sys.executable, "-m", "nnfmu.cli", "system", "build", str(at_h), "--out", str(out), "--step", "1e-3"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "2 FMUs stepped at 0.001 s; 2 inputs, 9 outputs, 4 parameters" in done.stdout and out.is_file()
    assert "binaries: linux64" in done.stdout.splitlines()  # its parts' platform (the suite builds them for it)


SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]


def driven(fmu: Path, folder: Path, sanitize: list[str], steps: int, fmi: int = 2) -> tuple[list[str], dict[str, str]]:
    """The command running tests/cosim/container/system_driver.c (FMI 2) or system_driver3.c (FMI 3) on the unpacked
    `fmu` (its binary rebuilt from its shipped sources with `sanitize` when given), and the environment to run it
    in."""
    import zipfile

    from fmpy import read_model_description

    from nnfmu.fmu.native.backend import fmi_headers_dir

    unpacked = folder / "car"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(unpacked)
    description = read_model_description(str(fmu))
    sources = unpacked / "sources"
    flags = ["gcc", "-std=c99", "-g", "-Wall", "-Wextra", "-Werror", "-Wvla", *sanitize]
    platform = "linux64" if fmi == 2 else "x86_64-linux"
    library = unpacked / "binaries" / platform / f"{description.coSimulation.modelIdentifier}.so"
    driver = Path(__file__).with_name("system_driver.c" if fmi == 2 else "system_driver3.c")
    commands = [[*flags, f"-I{fmi_headers_dir()}", "-o", str(folder / "driver"), str(driver), "-ldl", "-lm"]]
    if sanitize:
        commands.append(
            [*flags, "-fPIC", "-shared", "-DNN_LOOP_HIDDEN", f"-I{sources}", "-o", str(library)]
            + [str(sources / name) for name in ("system_fmu.c" if fmi == 2 else "system_fmu3.c", "inner_loop.c")]
            + ["-lm", "-ldl"]
        )
    for command in commands:
        compiled = subprocess.run(command, capture_output=True, text=True, timeout=120)
        assert compiled.returncode == 0, compiled.stderr
    variables = description.modelVariables
    inputs = sum(v.causality == "input" for v in variables)
    outputs = sum(v.causality == "output" for v in variables)
    token = description.guid if fmi == 2 else description.instantiationToken
    resources = (unpacked / "resources").as_uri() if fmi == 2 else f"{unpacked / 'resources'}/"
    command = [str(folder / "driver"), str(library), token, resources, str(inputs), str(outputs), str(steps)]
    if fmi == 3:
        command.append(str(next(v.valueReference for v in variables if v.causality == "independent")))
    return command, {"ASAN_OPTIONS": "detect_leaks=1", "PATH": "/usr/bin:/bin"}


@pytest.mark.slow
@pytest.mark.parametrize(("parts", "fmi"), [(2, 2), (3, 2), (2, 3)], ids=["fmi2", "fmi3-parts", "fmi3"])
def test_the_system_fmus_master_runs_clean_under_asan_and_ubsan(request, parts: int, fmi: int, tmp_path: Path) -> None:
    """Its shipped sources, compiled with ASan and UBSan, run 200 steps twice (reset between) with a refused
    instantiation, a refused step and the state saved, serialised (and refused cut short), deserialised, restored
    and freed: over FMI 2 parts, over FMI 3 parts, and as an FMI 3 system FMU: no sanitizer report, no leak, no
    unexpected status."""
    ssd = request.getfixturevalue("at_h" if parts == 2 else "at_h_fmi3")
    command, environment = driven(build(ssd, tmp_path / "car.fmu", fmi=fmi), tmp_path, SANITIZE, 200, fmi)
    result = subprocess.run(command, capture_output=True, text=True, timeout=300, env=environment)
    assert result.returncode == 0, result.stderr[-4000:]
    assert "0 unexpected statuses" in result.stderr and "runtime error" not in result.stderr


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_the_system_fmu_runs_clean_under_valgrind(at_h: Path, tmp_path: Path) -> None:
    """The FMU's own binary (and its parts') under valgrind over the same cycle, 50 steps a run: no error, no leak."""
    command, environment = driven(build(at_h, tmp_path / "car.fmu"), tmp_path, [], 50)
    valgrind = ["valgrind", "--error-exitcode=99", "--leak-check=full"]
    valgrind += ["--errors-for-leak-kinds=definite,indirect,possible", "--show-leak-kinds=definite,indirect,possible"]
    result = subprocess.run([*valgrind, *command], capture_output=True, text=True, timeout=300, env=environment)
    assert result.returncode == 0, result.stderr[-4000:]
    assert "0 unexpected statuses" in result.stderr and "ERROR SUMMARY: 0 errors" in result.stderr


def test_libcosim_and_nnfmus_plain_master_step_it_as_a_plain_fmi_loop_does(at_h: Path, tmp_path: Path) -> None:
    """The system FMU as the one element of an SSP system: libcosim (its own fixed-step algorithm) and nnfmu's master
    with the plain Jacobi settings both set the drive at t_n and no slopes, as the plain loop without slopes does; all
    three agree within 1e-12 on every output."""
    pytest.importorskip("libcosimpy")
    from nnfmu.cosim.binding import DriveBinding
    from nnfmu.cosim.libcosim_runner import run_libcosim

    fmu = build(at_h, tmp_path / "car.fmu")
    ssd = write_ssd(connect_by_name("one car", ("car", fmu), {}, tmp_path), tmp_path / "system.ssd")
    plain = CosimSettings(step=H, scheme="jacobi", extrapolation="none", refresh=False, **NO_DERIVATIVES)
    binding = DriveBinding.by_name("car", ("actuator_fl_displacement", "actuator_fl_velocity"))
    source = drive(DURATION, H, corner="fl")
    loop, _ = run(fmu, slopes=False)
    libcosim = run_libcosim(ssd, source, plain, binding).measurement
    with open_system(ssd) as system:
        fmpy = cosimulate(system, source, plain, binding=binding).measurement
    for other in (libcosim, fmpy):
        errors = worst(loop, {name: other[name] for name in loop})
        assert max(errors.values()) <= TOLERANCE, errors
    assert np.ptp(loop["damper_force"]) > 100.0


@pytest.mark.parametrize("fmi", [2, 3])
def test_the_whole_systems_state_is_saved_restored_and_serialised(at_h: Path, tmp_path: Path, fmi: int) -> None:
    """A state saved after 50 steps (every part's and the master's own), restored after 50 more, gives those 50
    steps again bit for bit; so does the state serialised, deserialised and restored (FMI 2 and FMI 3 system FMU)."""
    slave = FmuSlave(build(at_h, tmp_path / "car.fmu", fmi=fmi), instance_name="car")
    inputs, outputs = slave.names("input"), slave.names("output")
    source = drive(DURATION, H, corner="fl")
    u = np.column_stack([source[name] for name in inputs])
    references = slave.value_references(inputs)

    def steps(first: int, last: int) -> np.ndarray:
        rows = []
        for n in range(first, last):
            slave.set_real(inputs, u[n])
            if fmi == 2:
                slave.fmu.setRealInputDerivatives(references, [1] * len(inputs), list((u[n + 1] - u[n]) / H))
            slave.do_step(n * H, H)
            rows.append(slave.get_real(outputs))
        return np.array(rows)

    try:
        slave.enter_initialization(0.0)
        slave.set_real(inputs, u[0])
        slave.exit_initialization()
        steps(0, 50)
        state = slave.fmu.getFMUState()
        first = steps(50, 100)
        slave.fmu.setFMUState(state)
        again = steps(50, 100)
        serialised = slave.fmu.serializeFMUState(state)
        slave.fmu.freeFMUState(state)
        restored = slave.fmu.deserializeFMUState(serialised)
        slave.fmu.setFMUState(restored)
        slave.fmu.freeFMUState(restored)
        third = steps(50, 100)
    finally:
        slave.close()
    assert np.array_equal(first, again) and np.array_equal(first, third)
    assert np.ptp(first[:, outputs.index("damper_force")]) > 10.0  # the steps moved the car


def test_it_runs_inside_an_fmu_manipulation_toolbox_container(at_h: Path, tmp_path: Path) -> None:
    """Nested in fmu-manipulation-toolbox's FMU container (inputs and outputs exposed by name, its step 1 ms), it
    gives its own numbers in a plain loop without slopes, within 1e-12 on every output."""
    pytest.importorskip("fmu_manipulation_toolbox")
    from fmu_manipulation_toolbox.assembly import AssemblyNode

    build(at_h, tmp_path / "car.fmu")
    node = AssemblyNode("outer.fmu", step_size=H)
    node.add_fmu("car.fmu")
    node.make_fmu(tmp_path)
    nested, _ = run(tmp_path / "outer.fmu", slopes=False)
    alone, _ = run(tmp_path / "car.fmu", slopes=False)
    assert set(alone) <= set(nested)
    errors = worst({name: nested[name] for name in alone}, alone)
    assert max(errors.values()) <= TOLERANCE, errors
    assert np.ptp(nested["damper_force"]) > 100.0
