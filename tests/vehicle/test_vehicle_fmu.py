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
from nnfmu.export.step_runner import run_step_graph
from nnfmu.fmu.errors import FmuBuildError
from nnfmu.vehicle.dynamics import (
    LinearVehicle,
    SimulationSettings,
    SplineDamper,
    VehicleModelError,
    VehicleParameters,
    simulate,
)
from nnfmu.vehicle.dynamics.full_vehicle import COMPONENTS as FULL_VEHICLE_COMPONENTS
from nnfmu.vehicle.dynamics.ports import component_channels
from nnfmu.vehicle.fmu import (
    VehicleBuildError,
    VehicleBuildSettings,
    build_vehicle_fmu,
    spline_terms,
    vehicle_model,
    vehicle_step_graph,
)

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
    vehicle: LinearVehicle, period: float, knots: dict[str, np.ndarray], x0: np.ndarray
) -> dict[str, np.ndarray]:
    """The step graph's samples by the vehicle model's own stepping: sample k (k >= 1) advances one period from
    sample k-1 with the inputs linear from `knots` k-1 to k over that interval, and reports the outputs with the
    inputs of sample k; sample 0 reports x0."""
    n = len(next(iter(knots.values())))
    discrete = vehicle.discretise(period, "foh")
    x, rows, before = np.asarray(x0, dtype=float), [], None
    for k in range(n):
        u = vehicle.input_vector({name: values[k] for name, values in knots.items()})
        if k:
            x = discrete.step(x, before, u)
        rows.append(vehicle.output_vector(x, u))
        before = u
    table = np.array(rows)
    return {name: table[:, i] for i, name in enumerate(vehicle.output_names)}


def _interpolating_fmu(
    vehicle: LinearVehicle, period: float, step: float, inputs: dict[str, np.ndarray], x0: np.ndarray, settle: bool
) -> dict[str, np.ndarray]:
    """docs/fmu.md's semantics of an FMU that interpolates its inputs, computed with the model's own stepping.

    `inputs` row m is set at t_m = m step (row 0 during initialisation); returns the outputs read after
    initialisation and after every step. A sample evaluated in a step takes the inputs set before it; inputs set at
    the latest sample's time become that sample's, which is evaluated again. With `settle`, row m + 1 is set right
    after step m and before the outputs are read (a master resolving feedthrough), else before step m + 1."""
    discrete = vehicle.discretise(period, "foh")
    rows = [
        vehicle.input_vector({name: values[m] for name, values in inputs.items()})
        for m in range(len(next(iter(inputs.values()))))
    ]
    knots, states = [rows[0]], [np.asarray(x0, dtype=float)]

    def set_inputs(u: np.ndarray, now: float) -> None:
        latest = len(knots) - 1
        if abs(latest * period - now) <= 1e-6 * period and not np.array_equal(u, knots[latest]):
            knots[latest] = u
            if latest:
                states[latest] = discrete.step(states[latest - 1], knots[latest - 1], u)

    read = [vehicle.output_vector(states[0], knots[0])]
    current = rows[0]
    for m in range(1, len(rows)):
        t = (m - 1) * step
        set_inputs(current, t)
        while len(knots) * period <= t + step + 1e-6 * period:
            states.append(discrete.step(states[-1], knots[-1], current))
            knots.append(current)
        current = rows[m]
        if settle:
            set_inputs(current, t + step)
        read.append(vehicle.output_vector(states[-1], knots[-1]))
    table = np.array(read)
    return {name: table[:, i] for i, name in enumerate(vehicle.output_names)}


def _run_fmu(path: Path, inputs: dict[str, np.ndarray], step: float, settle: bool) -> dict[str, np.ndarray]:
    """Drive an FMU from t = 0 with communication step `step`, row m of `inputs` set at t_m (as in
    `_interpolating_fmu`, with or without `settle`). Returns the outputs after initialisation and every step."""
    n = len(next(iter(inputs.values())))
    names = list(inputs)
    with FmuSlave(path) as slave:
        outputs = slave.names("output")
        outputs.remove("extrapolating")
        slave.enter_initialization(0.0)
        slave.set_real(names, [inputs[k][0] for k in names])
        slave.exit_initialization()
        rows = [slave.get_real(outputs)]
        for m in range(1, n):
            if not settle:
                slave.set_real(names, [inputs[name][m - 1] for name in names])
            slave.do_step((m - 1) * step, step)
            if settle:
                slave.set_real(names, [inputs[name][m] for name in names])
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
        "stabilised": build_vehicle_fmu(
            "quarter-car", folder / "stabilised.fmu", VehicleBuildSettings(components={"damper": "stabilised"})
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
        # linear with held ports: the stabiliser and the held ports folded into one step matrix
        ("quarter-car", {"damper": "stabilised"}),
        ("full-vehicle", {k: "stabilised" for k in ALL_REFERENCE if k.startswith("bushing")}),
    ],
)
@pytest.mark.slow
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


@pytest.mark.slow
@pytest.mark.parametrize("settle", [True, False])
@pytest.mark.parametrize("kind", ["external", "reference", "stabilised"])
def test_quarter_car_fmu_equals_the_model(quarter_car_fmus: dict[str, Path], kind: str, settle: bool) -> None:
    """Random actuator input (and damper force, for the external damper) through fmpy, one sample per step: the
    outputs equal the model's own stepping under docs/fmu.md's input interpolation; a master that sets each step's
    inputs at its end (`settle`) reads `simulate` with a first-order hold, one that sets them only before a step
    reads each sample predicted with the inputs held, the state following the first-order hold all the same."""
    path = quarter_car_fmus[kind]
    assert validate_fmu(str(path)) == []
    settings = VehicleBuildSettings(components={"damper": kind})
    vehicle = vehicle_model("quarter-car", settings)
    x0 = _initial_state(vehicle_step_graph("quarter-car", settings))
    inputs = _random_inputs(vehicle, 2000)
    got = _run_fmu(path, inputs, T, settle)
    _assert_close(got, _interpolating_fmu(vehicle, T, T, inputs, x0, settle), vehicle.output_names)
    foh = simulate(vehicle, inputs, SimulationSettings(dt=T, hold="foh"), x0=x0)
    if settle:
        _assert_close(got, foh, vehicle.output_names)
    else:
        late = {name: values[1:] for name, values in got.items()}
        assert max(np.max(np.abs(late[n] - foh[n][1:])) / np.ptp(foh[n]) for n in vehicle.output_names) > 1e-6
    assert np.ptp(got["damper_velocity"]) > 0.05  # the spline is driven across several knots


def test_outputs_read_in_one_call_equal_outputs_read_one_by_one(quarter_car_fmus: dict[str, Path]) -> None:
    """A GetReal of all outputs (an input first) after the inputs are set at the latest sample's time, which settles
    that sample once for the whole call, gives each output bit for bit as reading them one call each does."""
    vehicle = vehicle_model("quarter-car", VehicleBuildSettings())
    inputs = _random_inputs(vehicle, 50)
    names = list(inputs)
    tables = []
    for one_by_one in (False, True):
        with FmuSlave(quarter_car_fmus["external"]) as slave:
            read = [names[0], *(o for o in slave.names("output") if o != "extrapolating")]
            slave.enter_initialization(0.0)
            slave.set_real(names, [inputs[k][0] for k in names])
            slave.exit_initialization()
            rows = []
            for m in range(1, 50):
                slave.do_step((m - 1) * T, T)
                slave.set_real(names, [inputs[k][m] for k in names])
                rows.append([slave.get_real([r])[0] for r in read] if one_by_one else list(slave.get_real(read)))
        tables.append(np.array(rows))
    assert np.array_equal(tables[0], tables[1])
    assert np.ptp(tables[0][:, 1:], axis=0).max() > 0.0


def test_vehicle_fmu_does_not_filter_its_outputs(quarter_car_fmus: dict[str, Path]) -> None:
    description = read_model_description(str(quarter_car_fmus["external"]))
    starts = {v.name: v.start for v in description.modelVariables if v.causality == "parameter"}
    assert float(starts["filter_cutoff"]) == 0.0 and float(starts["output_gain"]) == 1.0
    with FmuSlave(quarter_car_fmus["external"]) as slave:
        slave.enter_initialization(0.0)
        assert slave.get_real(["filter_cutoff"])[0] == 0.0


@pytest.mark.slow
def test_full_vehicle_with_reference_components_runs_alone_and_equals_simulate(tmp_path: Path) -> None:
    settings = VehicleBuildSettings(components=ALL_REFERENCE, fmi_version=3)
    path = build_vehicle_fmu("full-vehicle", tmp_path / "full_vehicle.fmu", settings)
    assert validate_fmu(str(path)) == []
    vehicle = vehicle_model("full-vehicle", settings)
    assert [p.name for p in vehicle.inputs if not p.name.startswith("actuator")] == []
    x0 = _initial_state(vehicle_step_graph("full-vehicle", settings))
    inputs = _random_inputs(vehicle, 1500, seed=5)
    got = _run_fmu(path, inputs, T, settle=True)
    _assert_close(got, simulate(vehicle, inputs, SimulationSettings(dt=T, hold="foh"), x0=x0), vehicle.output_names)


@pytest.mark.slow
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


@pytest.mark.parametrize("settle", [True, False])
def test_communication_step_of_two_and_a_half_periods(quarter_car_fmus: dict[str, Path], settle: bool) -> None:
    """docs/fmu.md: a step of 2.5 T evaluates two or three samples with the inputs set before it; only a sample on
    a communication point (every other step) takes the inputs set there; outputs are the latest sample's."""
    settings = VehicleBuildSettings(components={"damper": "reference"})
    vehicle = vehicle_model("quarter-car", settings)
    x0 = _initial_state(vehicle_step_graph("quarter-car", settings))
    drive = _random_inputs(vehicle, 401, seed=11)
    got = _run_fmu(quarter_car_fmus["reference"], drive, 2.5 * T, settle)
    _assert_close(got, _interpolating_fmu(vehicle, T, 2.5 * T, drive, x0, settle), vehicle.output_names)


def test_component_filter_cutoff_defaults_to_off_and_round_trips() -> None:
    ports = [Port("velocity", "m/s")], [Port("force", "N")]
    assert Component("damper", *ports).filter_cutoff == 0.0
    legacy = Component("damper", *ports).to_dict()
    del legacy["filter_cutoff"]
    assert Component.from_dict(legacy).filter_cutoff == 0.0
    assert Component.from_dict(Component("damper", *ports, filter_cutoff=100.0).to_dict()).filter_cutoff == 100.0
    with pytest.raises(ValueError, match="filter_cutoff"):
        Component("damper", *ports, filter_cutoff=-1.0)


def test_the_pythonfmu_backend_refuses_a_vehicle_naming_the_native_one(tmp_path: Path) -> None:
    """A vehicle interpolates its inputs between samples, which the pythonfmu runtimes cannot offer."""
    with pytest.raises(FmuBuildError, match="interpolates its inputs.*native backend"):
        build_vehicle_fmu("quarter-car", tmp_path / "qc.fmu", VehicleBuildSettings(backend="pythonfmu"))
    assert not (tmp_path / "qc.fmu").exists()


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
    [
        ({"sample_period": 0.0}, "sample period"),
        ({"components": {"damper": "spline"}}, "choice"),
        ({"fmi_version": 1}, "FMI version"),
        ({"initial_state": (0.0, math.nan)}, "initial state"),
        ({"stabilisers": {"damper_force": (1.0, -2.0)}}, "stabiliser"),
        ({"stabilisers": {"damper_force": (math.inf, 2.0)}}, "stabiliser"),
        ({"stabilisers": {"damper_force": (0.0, 0.0)}}, "stabiliser"),
        ({"stabilisers": {"damper_force": (1.0,)}}, "stabiliser"),
    ],
)
def test_bad_settings_are_refused(kwargs: dict, message: str) -> None:
    with pytest.raises(VehicleBuildError, match=message):
        VehicleBuildSettings(**kwargs)


@pytest.mark.parametrize(
    ("model", "components", "port", "deflection", "rate"),
    [
        (
            "full-vehicle",
            {"bushing_fl_front": "stabilised"},
            "bushing_fl_front_radial_force",
            "bushing_fl_front_radial_displacement",
            "bushing_fl_front_radial_velocity",
        ),
        (
            "full-vehicle",
            {"bushing_fr_rear": "stabilised"},
            "bushing_fr_rear_conical_torque",
            "bushing_fr_rear_conical_rotation",
            "bushing_fr_rear_conical_angular_velocity",
        ),
        (
            "full-vehicle",
            {"damper_rl": "stabilised"},
            "damper_rl_force",
            "damper_rl_displacement",
            "damper_rl_velocity",
        ),
        ("quarter-car", {"damper": "stabilised"}, "damper_force", "damper_displacement", "damper_velocity"),
    ],
)
def test_a_given_stabiliser_replaces_only_its_ports_element(
    model: str, components: dict, port: str, deflection: str, rate: str
) -> None:
    """The stabiliser row of the named port is k times its deflection plus c times its rate; every other row is
    the parameter file's."""
    plain = vehicle_model(model, VehicleBuildSettings(components=components))
    given = vehicle_model(model, VehicleBuildSettings(components=components, stabilisers={port: (7.5e6, 3.0e3)}))
    i = plain.input_index(port)
    position, velocity = plain.C[plain.output_index(deflection)], plain.C[plain.output_index(rate)]
    np.testing.assert_allclose(given.stabiliser[i], 7.5e6 * position + 3.0e3 * velocity, rtol=1e-12, atol=1e-9)
    others = np.arange(len(plain.inputs)) != i
    np.testing.assert_array_equal(given.stabiliser[others], plain.stabiliser[others])
    assert np.any(plain.stabiliser[i] != given.stabiliser[i])


@pytest.mark.parametrize(
    ("components", "port"),
    [
        ({}, "bushing_fl_front_radial_force"),  # external, not stabilised
        ({"bushing_fl_front": "reference"}, "bushing_fl_front_radial_force"),  # built in: no port
        ({"bushing_fl_front": "stabilised"}, "bushing_fl_front_shear_force"),  # no such port
    ],
)
def test_a_stabiliser_for_no_stabilised_port_is_refused_naming_it(components: dict, port: str) -> None:
    with pytest.raises(VehicleBuildError, match=port):
        vehicle_model("full-vehicle", VehicleBuildSettings(components=components, stabilisers={port: (1.0, 1.0)}))


def test_input_derivatives_give_the_first_order_hold_without_a_second_set(quarter_car_fmus: dict[str, Path]) -> None:
    """FMI 2: inputs set at t_m with their slopes toward t_{m+1}: every sample is evaluated once, with the
    first-order hold, and nothing is evaluated again; the model description says so."""
    path = quarter_car_fmus["external"]
    description = read_model_description(str(path))
    assert description.coSimulation.canInterpolateInputs is True
    accelerating = next(o for o in description.outputs if o.variable.name == "body_acceleration")
    assert "damper_force" in [d.name for d in accelerating.dependencies]  # feedthrough at communication points
    settings = VehicleBuildSettings()
    vehicle = vehicle_model("quarter-car", settings)
    x0 = _initial_state(vehicle_step_graph("quarter-car", settings))
    inputs = _random_inputs(vehicle, 600, seed=8)
    names = list(inputs)
    with FmuSlave(path) as slave:
        refs = slave.value_references(names)
        slave.enter_initialization(0.0)
        slave.set_real(names, [inputs[k][0] for k in names])
        slave.exit_initialization()
        rows = [slave.get_real(vehicle.output_names)]
        for m in range(1, 600):
            slave.set_real(names, [inputs[k][m - 1] for k in names])
            slave.fmu.setRealInputDerivatives(
                refs, [1] * len(refs), [(inputs[k][m] - inputs[k][m - 1]) / T for k in names]
            )
            slave.do_step((m - 1) * T, T)
            rows.append(slave.get_real(vehicle.output_names))
    table = np.array(rows)
    got = {name: table[:, i] for i, name in enumerate(vehicle.output_names)}
    _assert_close(got, simulate(vehicle, inputs, SimulationSettings(dt=T, hold="foh"), x0=x0), vehicle.output_names)


def test_a_given_initial_state_is_where_the_fmu_starts() -> None:
    """A road test starts the vehicle where its components rest (`rest_state`): the graph's state starts there; a
    state of the wrong length is refused with both counts."""
    vehicle = vehicle_model("quarter-car", VehicleBuildSettings())
    start = tuple(0.001 * (i + 1) for i in range(len(vehicle.states)))
    np.testing.assert_array_equal(
        _initial_state(vehicle_step_graph("quarter-car", VehicleBuildSettings(initial_state=start))), start
    )
    with pytest.raises(VehicleBuildError, match=f"initial state has 2 values; the vehicle has {len(start)} states"):
        vehicle_step_graph("quarter-car", VehicleBuildSettings(initial_state=(0.0, 0.0)))


@pytest.mark.parametrize("at", ["initialization", "step"])
def test_directional_derivatives_are_those_of_the_outputs_at_the_communication_point(
    quarter_car_fmus: dict[str, Path], at: str
) -> None:
    """Inputs set at a communication point move the outputs there (the latest sample is evaluated again, or the
    preview before initialisation ends): fmi2GetDirectionalDerivative equals their central differences."""
    with FmuSlave(quarter_car_fmus["external"]) as slave:
        inputs = slave.names("input")
        outputs = [name for name in slave.names("output") if name != "extrapolating"]
        rng = np.random.default_rng(5)
        values = rng.normal(size=len(inputs)) * np.array([1e-3 if slave.unit(n) != "N" else 300.0 for n in inputs])
        slave.enter_initialization(0.0)
        slave.set_real(inputs, values)
        if at == "step":
            slave.exit_initialization()
            for m in range(10):
                slave.set_real(inputs, values * (1.0 + 0.1 * m))
                slave.do_step(m * 1e-3, 1e-3)
            values = values * 2.0
            slave.set_real(inputs, values)
        unknowns, knowns = slave.value_references(outputs), slave.value_references(inputs)
        for j, vr in enumerate(knowns):
            step = 1e-6 * max(1.0, abs(values[j]))
            sides = []
            for sign in (1.0, -1.0):
                moved = values.copy()
                moved[j] += sign * step
                slave.set_real(inputs, moved)
                sides.append(slave.get_real(outputs))
            slave.set_real(inputs, values)
            central = (sides[0] - sides[1]) / (2.0 * step)
            derivative = np.array(slave.fmu.getDirectionalDerivative(unknowns, [vr], [1.0]))
            scale = max(float(np.abs(central).max()), 1e-12)
            assert np.abs(central).max() > 0.0, inputs[j]
            np.testing.assert_allclose(derivative, central, rtol=1e-6, atol=1e-7 * scale, err_msg=inputs[j])
