"""Vehicle FMUs: the step graph and the built FMU against the vehicle model's own discrete simulation (`simulate`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from nnfmu.component import Component, Port
from nnfmu.cosim.slave import FmuSlave
from nnfmu.export.run import run_step_graph
from nnfmu.vehicle.fmu import (
    VehicleBuildError,
    VehicleBuildSettings,
    build_vehicle_fmu,
    spline_terms,
    vehicle_model,
    vehicle_step_graph,
)
from nnfmu.vehicle.models import (
    LinearVehicle,
    SimulationSettings,
    SplineDamper,
    VehicleModelError,
    VehicleParameters,
    simulate,
)
from nnfmu.vehicle.models.full_vehicle import COMPONENTS as FULL_VEHICLE_COMPONENTS
from nnfmu.vehicle.models.ports import component_channels

T = 1e-4  # the default internal sample period [s]
ALL_REFERENCE = {name: "reference" for name in FULL_VEHICLE_COMPONENTS}
RTOL = 1e-9  # of each output channel's largest magnitude


def _random_inputs(vehicle: LinearVehicle, n: int, seed: int = 3) -> dict[str, np.ndarray]:
    """Band-limited random inputs: 5 mm, 50 mm/s, 300 N (or N.m) scale, smoothed over 20 samples."""
    rng = np.random.default_rng(seed)
    scale = {"m": 5e-3, "m/s": 5e-2, "N": 300.0, "N.m": 30.0}
    kernel = np.ones(20) / 20.0
    return {
        p.name: scale[p.unit] * np.convolve(rng.normal(size=n + 19), kernel, mode="valid") * math.sqrt(20.0)
        for p in vehicle.inputs
    }


def _initial_state(graph) -> np.ndarray:  # noqa: ANN001 (onnx.ModelProto)
    return np.array(Component.from_onnx(graph).states[0].initial)


def _assert_close(got: dict[str, np.ndarray], want: dict[str, np.ndarray], names: list[str]) -> None:
    """Every channel within RTOL of its largest magnitude."""
    for name in names:
        scale = max(float(np.max(np.abs(want[name]))), 1e-30)
        error = float(np.max(np.abs(got[name] - want[name]))) / scale
        assert error <= RTOL, f"{name}: relative error {error:.3g}"


def _reference(
    vehicle: LinearVehicle, period: float, held: dict[str, np.ndarray], x0: np.ndarray
) -> dict[str, np.ndarray]:
    """The FMU's samples by the vehicle model's own stepping: sample k (k >= 1) advances one period from sample k-1
    with the inputs `held` over that interval, and reports the outputs with those inputs; sample 0 reports x0."""
    n = len(next(iter(held.values())))
    discrete = vehicle.discretise(period, "zoh")
    x, rows = np.asarray(x0, dtype=float), []
    for k in range(n):
        u = vehicle.input_vector({name: values[k] for name, values in held.items()})
        if k:
            x = discrete.step(x, u)
        rows.append(vehicle.output_vector(x, u))
    table = np.array(rows)
    return {name: table[:, i] for i, name in enumerate(vehicle.output_names)}


def _held_one_step(inputs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """What each sample sees when the inputs of sample m are set before the step from t_m to t_m + T."""
    return {name: np.concatenate([values[:1], values[:-1]]) for name, values in inputs.items()}


def _no_feedthrough(vehicle: LinearVehicle) -> list[str]:
    """Outputs that depend on the state only (no D or Dyn term): where the FMU and `simulate` agree sample by sample."""
    dyn = vehicle.Dyn if vehicle.Dyn.size else np.zeros((len(vehicle.outputs), 1))
    return [p.name for i, p in enumerate(vehicle.outputs) if not vehicle.D[i].any() and not dyn[i].any()]


def _run_fmu(path: Path, inputs: dict[str, np.ndarray], step: float, period: float) -> dict[str, np.ndarray]:
    """Drive an FMU from t = 0 with communication step `step`; before each step the inputs are set to those of the
    sample at its start. Returns the outputs after initialisation and after every step."""
    n = len(next(iter(inputs.values())))
    names = list(inputs)
    with FmuSlave(path) as slave:
        outputs = slave.names("output")
        outputs.remove("extrapolating")
        slave.enter_initialization(0.0)
        slave.set_real(names, [inputs[k][0] for k in names])
        slave.exit_initialization()
        rows = [slave.get_real(outputs)]
        t, m = 0.0, 0
        while len(rows) < n:
            k = int(round(m * step / period))
            slave.set_real(names, [inputs[name][k] for name in names])
            slave.do_step(t, step)
            m += 1
            t = m * step
            rows.append(slave.get_real(outputs))
    table = np.array(rows)
    return {name: table[:, i] for i, name in enumerate(outputs)}


@pytest.fixture(scope="module")
def quarter_car_fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("quarter_car")
    return {
        "external": build_vehicle_fmu("quarter-car", folder / "external.fmu", VehicleBuildSettings()),
        "reference": build_vehicle_fmu(
            "quarter-car", folder / "reference.fmu", VehicleBuildSettings(components={"damper": "reference"})
        ),
    }


def test_spline_terms_reproduce_the_spline_table_and_its_extension() -> None:
    params = VehicleParameters.load()
    laws = [
        SplineDamper(params.front_damper.velocity, params.front_damper.force),
        SplineDamper(params.rear_damper.velocity, params.rear_damper.force),
        SplineDamper((-1.0, 2.0), (-10.0, 40.0)),  # two points: a straight line, no kinks
    ]
    terms = spline_terms(laws)
    v = np.linspace(-2.5, 2.5, 1001)
    for j, law in enumerate(laws):
        row = np.zeros((v.size, len(laws)))
        row[:, j] = v
        relu = np.maximum(row @ terms.select - terms.knots, 0.0)
        force = row * terms.slope + terms.offset + relu @ terms.kink_slopes
        np.testing.assert_allclose(force[:, j], law(v), rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("period", [1e-4, 5e-4])
@pytest.mark.parametrize(
    ("model", "components"),
    [
        ("quarter-car", {}),
        ("quarter-car", {"damper": "reference"}),
        ("full-vehicle", ALL_REFERENCE),
        ("full-vehicle", {k: "stabilised" if k.startswith("bushing") else "reference" for k in ALL_REFERENCE}),
    ],
)
def test_step_graph_in_onnxruntime_equals_the_model(model: str, components: dict[str, str], period: float) -> None:
    """Sample by sample against the model's own stepping; at 0.5 ms the graph unrolls 5 predictor-corrector
    sub-steps of the spline dampers."""
    settings = VehicleBuildSettings(components=components, sample_period=period)
    graph = vehicle_step_graph(model, settings)
    vehicle = vehicle_model(model, settings)
    inputs = _random_inputs(vehicle, 400)
    got = run_step_graph(graph, inputs)
    _assert_close(got, _reference(vehicle, period, inputs, _initial_state(graph)), vehicle.output_names)


def test_initial_state_is_the_static_equilibrium() -> None:
    """A run without input stays at rest: the state of sample 1 equals that of sample 0."""
    settings = VehicleBuildSettings(components=ALL_REFERENCE)
    graph = vehicle_step_graph("full-vehicle", settings)
    vehicle = vehicle_model("full-vehicle", settings)
    x0 = _initial_state(graph)
    np.testing.assert_allclose(x0, vehicle.equilibrium(), rtol=0, atol=0)
    assert np.max(np.abs(x0)) > 1e-7  # the LCA weight deflects the bushings a little: not the design position
    result = run_step_graph(graph, {p.name: np.zeros(50) for p in vehicle.inputs})
    for name in ("body_heave", "bushing_fl_front_axial_displacement", "spindle_fl_vertical_force"):
        np.testing.assert_allclose(result[name], result[name][0], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("kind", ["external", "reference"])
def test_quarter_car_fmu_equals_the_model(quarter_car_fmus: dict[str, Path], kind: str) -> None:
    """Random actuator input (and damper force, for the external damper) through fmpy, one sample per step: the
    outputs equal the model's own stepping, and those without feedthrough equal `simulate` (ZOH) directly."""
    path = quarter_car_fmus[kind]
    assert validate_fmu(str(path)) == []
    settings = VehicleBuildSettings(components={"damper": kind})
    vehicle = vehicle_model("quarter-car", settings)
    x0 = _initial_state(vehicle_step_graph("quarter-car", settings))
    inputs = _random_inputs(vehicle, 2000)
    got = _run_fmu(path, inputs, T, T)
    _assert_close(got, _reference(vehicle, T, _held_one_step(inputs), x0), vehicle.output_names)
    state_only = _no_feedthrough(vehicle)
    assert {"damper_displacement", "damper_velocity", "body_displacement"} <= set(state_only)
    _assert_close(got, simulate(vehicle, inputs, SimulationSettings(dt=T), x0=x0), state_only)
    assert np.ptp(got["damper_velocity"]) > 0.05  # the spline is driven across several knots


def test_vehicle_fmu_does_not_filter_its_outputs(quarter_car_fmus: dict[str, Path]) -> None:
    description = read_model_description(str(quarter_car_fmus["external"]))
    starts = {v.name: v.start for v in description.modelVariables if v.causality == "parameter"}
    assert float(starts["filter_cutoff"]) == 0.0 and float(starts["output_gain"]) == 1.0
    with FmuSlave(quarter_car_fmus["external"]) as slave:
        slave.enter_initialization(0.0)
        assert slave.get_real(["filter_cutoff"])[0] == 0.0


def test_full_vehicle_with_reference_components_runs_alone_and_equals_simulate(tmp_path: Path) -> None:
    settings = VehicleBuildSettings(components=ALL_REFERENCE, fmi_version=3)
    path = build_vehicle_fmu("full-vehicle", tmp_path / "full_vehicle.fmu", settings)
    assert validate_fmu(str(path)) == []
    vehicle = vehicle_model("full-vehicle", settings)
    assert [p.name for p in vehicle.inputs if not p.name.startswith("actuator")] == []
    x0 = _initial_state(vehicle_step_graph("full-vehicle", settings))
    inputs = _random_inputs(vehicle, 1500, seed=5)
    got = _run_fmu(path, inputs, T, T)
    _assert_close(got, _reference(vehicle, T, _held_one_step(inputs), x0), vehicle.output_names)
    state_only = _no_feedthrough(vehicle)
    assert "bushing_fl_front_axial_displacement" in state_only and "damper_rr_velocity" in state_only
    _assert_close(got, simulate(vehicle, inputs, SimulationSettings(dt=T), x0=x0), state_only)


def test_full_vehicle_with_external_components_has_every_port_with_its_unit(tmp_path: Path) -> None:
    path = build_vehicle_fmu("full-vehicle", tmp_path / "external.fmu", VehicleBuildSettings())
    assert validate_fmu(str(path)) == []
    vehicle = vehicle_model("full-vehicle", VehicleBuildSettings())
    description = read_model_description(str(path))
    variables = {v.name: v for v in description.modelVariables}
    for causality, ports in (("input", vehicle.inputs), ("output", vehicle.outputs)):
        listed = [v.name for v in description.modelVariables if v.causality == causality and v.type == "Real"]
        assert listed == [p.name for p in ports]
        for port in ports:
            assert variables[port.name].unit == port.unit, port.name
    for component in FULL_VEHICLE_COMPONENTS:
        for force, displacement, rate in component_channels(component):
            assert variables[force].causality == "input", force
            assert variables[displacement].causality == variables[rate].causality == "output", component
    # external bushings leave the rest position to the connected components: the FMU starts at the design position
    assert not _initial_state(vehicle_step_graph("full-vehicle", VehicleBuildSettings())).any()
    assert "bushing_fl_front_conical_torque" in variables and variables["bushing_fl_front_conical_torque"].unit == "N.m"


def test_get_and_set_state_repeat_a_step_exactly(quarter_car_fmus: dict[str, Path]) -> None:
    """A master iterating a step: save, step, restore, step again with the same inputs gives bit-identical outputs."""
    with FmuSlave(quarter_car_fmus["reference"]) as slave:
        outputs = [name for name in slave.names("output") if name != "extrapolating"]
        slave.enter_initialization(0.0)
        slave.exit_initialization()
        slave.set_real(["actuator_fl_displacement", "actuator_fl_velocity"], [0.004, 0.3])
        for m in range(20):
            slave.do_step(m * 1e-3, 1e-3)
        saved = slave.get_state()
        slave.set_real(["actuator_fl_displacement", "actuator_fl_velocity"], [0.006, -0.2])
        slave.do_step(20e-3, 1e-3)
        first = slave.get_real(outputs)
        slave.set_state(saved)
        slave.set_real(["actuator_fl_displacement", "actuator_fl_velocity"], [-0.01, 0.1])  # a different guess first
        slave.do_step(20e-3, 1e-3)
        other = slave.get_real(outputs)
        slave.set_state(saved)
        slave.set_real(["actuator_fl_displacement", "actuator_fl_velocity"], [0.006, -0.2])
        slave.do_step(20e-3, 1e-3)
        again = slave.get_real(outputs)
        slave.free_state(saved)
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other)


def test_communication_step_of_two_and_a_half_periods(quarter_car_fmus: dict[str, Path]) -> None:
    """docs/fmu.md: a step of 2.5 T evaluates two or three samples with the inputs held; outputs are the latest."""
    settings = VehicleBuildSettings(components={"damper": "reference"})
    vehicle = vehicle_model("quarter-car", settings)
    x0 = _initial_state(vehicle_step_graph("quarter-car", settings))
    steps, h = 400, 2.5 * T
    drive = _random_inputs(vehicle, steps + 1, seed=11)
    samples = int(steps * 2.5) + 1
    # sample k (k >= 1) is evaluated in the step m with m h < k T <= (m + 1) h, with the inputs set before step m
    held = {name: np.array([values[0]] + [values[math.ceil(k / 2.5) - 1] for k in range(1, samples)])
            for name, values in drive.items()}
    want = _reference(vehicle, T, held, x0)
    with FmuSlave(quarter_car_fmus["reference"]) as slave:
        slave.enter_initialization(0.0)
        slave.set_real(list(drive), [v[0] for v in drive.values()])
        slave.exit_initialization()
        got = []
        for m in range(steps):
            slave.set_real(list(drive), [v[m] for v in drive.values()])
            slave.do_step(m * h, h)
            got.append(slave.get_real(vehicle.output_names))
    latest = [math.floor((m + 1) * 2.5 + 1e-6) for m in range(steps)]
    assert latest[:4] == [2, 5, 7, 10]
    table = np.array(got)
    _assert_close({name: table[:, i] for i, name in enumerate(vehicle.output_names)},
                  {name: want[name][latest] for name in vehicle.output_names}, vehicle.output_names)


def test_component_filter_cutoff_defaults_to_off_and_round_trips() -> None:
    ports = [Port("velocity", "m/s")], [Port("force", "N")]
    assert Component("damper", *ports).filter_cutoff == 0.0
    legacy = Component("damper", *ports).to_dict()
    del legacy["filter_cutoff"]
    assert Component.from_dict(legacy).filter_cutoff == 0.0
    assert Component.from_dict(Component("damper", *ports, filter_cutoff=100.0).to_dict()).filter_cutoff == 100.0
    with pytest.raises(ValueError, match="filter_cutoff"):
        Component("damper", *ports, filter_cutoff=-1.0)


def test_pythonfmu_backend_also_starts_with_the_filter_off(tmp_path: Path) -> None:
    path = build_vehicle_fmu("quarter-car", tmp_path / "qc.fmu", VehicleBuildSettings(backend="pythonfmu"))
    starts = {v.name: v.start for v in read_model_description(str(path)).modelVariables}
    assert float(starts["filter_cutoff"]) == 0.0
    with FmuSlave(path) as slave:
        slave.enter_initialization(0.0)
        assert slave.get_real(["filter_cutoff"])[0] == 0.0


@pytest.mark.parametrize(
    ("model", "settings", "message"),
    [
        ("half-car", VehicleBuildSettings(), "unknown vehicle model 'half-car'"),
        ("full-vehicle", VehicleBuildSettings(components={"damper_xx": "reference"}), "damper_xx"),
    ],
)
def test_bad_requests_name_the_value(tmp_path: Path, model: str, settings: VehicleBuildSettings, message: str) -> None:
    with pytest.raises(VehicleModelError, match=message):
        build_vehicle_fmu(model, tmp_path / "bad.fmu", settings)
    assert not (tmp_path / "bad.fmu").exists()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"sample_period": 0.0}, "sample period"), ({"components": {"damper": "spline"}}, "choice"),
     ({"fmi_version": 1}, "FMI version")],
)
def test_bad_settings_are_refused(kwargs: dict, message: str) -> None:
    with pytest.raises(VehicleBuildError, match=message):
        VehicleBuildSettings(**kwargs)
