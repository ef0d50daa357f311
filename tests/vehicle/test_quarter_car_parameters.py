"""Quarter-car parameter files: the packaged example equals the sedan's derived front-left corner, a minimal file with a
linear damper builds, the motion ratio means what the file says, and bad files are refused naming file and key."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from nnfmu.component import Component
from nnfmu.vehicle.dynamics import (
    ParameterError,
    QuarterCarParameters,
    VehicleModelError,
    VehicleParameters,
    build_quarter_car,
)
from nnfmu.vehicle.dynamics.parameters import DEFAULTS_DIR
from nnfmu.vehicle.fmu import VehicleBuildError, VehicleBuildSettings, vehicle_model, vehicle_step_graph

EXAMPLE = DEFAULTS_DIR / "midsize_sedan_quarter_car_fl.toml"
MATRICES = ("A", "B", "C", "D", "e", "gravity", "preload", "Bn", "Cn", "Dn", "Dyn", "stabiliser")
MINIMAL = """\
name = "test_car"
description = "hand-written quarter car, linear damper"
gravity = 9.81

[quarter_car]
corner = "fr"
sprung_mass = 320.0
unsprung_mass = 45.0
wheel_rate = 25000.0
tyre_stiffness = 200000.0
tyre_damping = 100.0
damper_motion_ratio = 0.8

[quarter_car.damper]
model = "linear"
damping = 3000.0
"""


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("components", [{}, {"damper": "reference"}, {"damper": "stabilised"}])
def test_the_packaged_example_is_the_sedans_front_left_quarter_car(components: dict[str, str]) -> None:
    from_file = QuarterCarParameters.load(EXAMPLE)
    derived = QuarterCarParameters.from_vehicle(VehicleParameters.load(), "fl")
    for field in fields(QuarterCarParameters):  # the file writes the derived values out exactly
        if field.name not in ("description", "source"):
            assert getattr(from_file, field.name) == getattr(derived, field.name), field.name
    assert from_file.corner == "fl" and from_file.damper.model == "spline"
    car, reference = build_quarter_car(from_file, components), build_quarter_car(derived, components)
    assert car.input_names == reference.input_names and car.output_names == reference.output_names
    assert car.feedback_laws == reference.feedback_laws
    for name in MATRICES:
        got, want = np.asarray(getattr(car, name)), np.asarray(getattr(reference, name))
        assert got.shape == want.shape, name
        scale = max(float(np.max(np.abs(want))), 1.0) if want.size else 1.0
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale, err_msg=name)


def test_the_default_build_derives_the_front_left_corner_and_builds_the_example_alike() -> None:
    derived = vehicle_model("quarter-car", VehicleBuildSettings())
    from_file = vehicle_model("quarter-car", VehicleBuildSettings(params_path=EXAMPLE))
    assert derived.name == from_file.name == "quarter_car_fl"
    np.testing.assert_allclose(from_file.A, derived.A, rtol=0, atol=1e-12 * np.max(np.abs(derived.A)))


def test_a_minimal_file_with_a_linear_damper_builds_and_its_ratio_damps_with_its_square(tmp_path: Path) -> None:
    """No body, rear axle, LCA or force table: the quarter car's modes are those of the two-mass system with the
    wheel rate and the damper's wheel damping c * ratio^2 (its stroke is ratio * travel, its force acts times ratio)."""
    params = QuarterCarParameters.load(_write(tmp_path, "quarter.toml", MINIMAL))
    assert params.corner == "fr" and params.damper.model == "linear" and params.damper.velocity == ()
    car = build_quarter_car(params, {"damper": "reference"})
    assert car.input_names == ["actuator_fr_displacement", "actuator_fr_velocity"]
    assert "(fr corner)" in car.description
    np.testing.assert_allclose(car.equilibrium(), 0.0, atol=1e-12)
    m_s, m_u, k, k_t = 320.0, 45.0, 25000.0, 200000.0
    c, c_t = 3000.0 * 0.8**2, 100.0
    mass = np.diag([m_s, m_u])
    stiffness = np.array([[k, -k], [-k, k + k_t]])
    damping = np.array([[c, -c], [-c, c + c_t]])
    first_order = np.block(
        [[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(mass, stiffness), -np.linalg.solve(mass, damping)]]
    )
    want = np.sort_complex(np.linalg.eigvals(first_order))
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(car.A)), want, rtol=1e-10)
    stroke = car.C[car.output_index("damper_displacement")]
    travel = car.C[car.output_index("body_displacement")] - car.C[car.output_index("spindle_displacement")]
    np.testing.assert_allclose(stroke, 0.8 * travel, rtol=0, atol=1e-15)


def test_derived_corners_take_their_axle_and_name_their_posts() -> None:
    vehicle = VehicleParameters.load()
    fl, fr = QuarterCarParameters.from_vehicle(vehicle, "fl"), QuarterCarParameters.from_vehicle(vehicle, "fr")
    assert replace(fr, corner="fl", description=fl.description, source=fl.source) == fl
    rr = QuarterCarParameters.from_vehicle(vehicle, "rr")
    assert rr.damper_motion_ratio == 0.85 and rr.wheel_rate == 27000.0 and rr.damper == vehicle.rear_damper
    assert rr.sprung_mass == pytest.approx(1300.0 * 1.16 / 2.75 / 2.0, rel=1e-12)
    assert fl.damper_motion_ratio == pytest.approx(0.67 / 0.69, rel=1e-15)  # damper_ratio 1 x the strut's cosine
    assert build_quarter_car(rr).input_names[:2] == ["actuator_rr_displacement", "actuator_rr_velocity"]
    with pytest.raises(VehicleModelError, match="corner 'front'; expected one of fl, fr, rl, rr"):
        QuarterCarParameters.from_vehicle(vehicle, "front")


def test_the_step_graph_records_the_corner(tmp_path: Path) -> None:
    settings = VehicleBuildSettings(params_path=_write(tmp_path, "quarter.toml", MINIMAL))
    component = Component.from_onnx(vehicle_step_graph("quarter-car", settings))
    assert component.metadata["corners"] == ["fr"] and "(fr corner)" in component.description
    assert [p.name for p in component.inputs] == ["actuator_fr_displacement", "actuator_fr_velocity", "damper_force"]
    full = Component.from_onnx(vehicle_step_graph("full-vehicle", VehicleBuildSettings()))
    assert full.metadata["corners"] == ["fl", "fr", "rl", "rr"]
    rear = Component.from_onnx(vehicle_step_graph("quarter-car", VehicleBuildSettings(corner="rl")))
    assert rear.metadata["corners"] == ["rl"]


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace("wheel_rate = 25000.0\n", ""), r"missing key 'quarter_car\.wheel_rate'"),
        (lambda t: t.replace('corner = "fr"\n', ""), r"missing key 'quarter_car\.corner'"),
        (
            lambda t: t.replace('corner = "fr"', 'corner = "front"'),
            r"quarter_car\.corner = 'front'; expected one of fl, fr, rl, rr",
        ),
        (lambda t: t.replace("wheel_rate = 25000.0", "wheel_rat = 25000.0"), r"missing key 'quarter_car\.wheel_rate'"),
        (
            lambda t: t.replace("wheel_rate = 25000.0", "wheel_rate = 25000.0\ncamber = 0.01"),
            r"unknown key\(s\) quarter_car\.camber",
        ),
        (
            lambda t: t.replace("damper_motion_ratio = 0.8", "damper_motion_ratio = -0.8"),
            r"quarter_car\.damper_motion_ratio = -0\.8 must be > 0",
        ),
        (
            lambda t: t.replace("damper_motion_ratio = 0.8", "damper_motion_ratio = 0.8\ndamper_ratio = 1.0"),
            r"quarter_car\.damper_ratio belongs to a full-vehicle parameter file.*damper_motion_ratio",
        ),
        (
            lambda t: t.replace("wheel_rate = 25000.0", "spring_rate = 25000.0"),
            r"quarter_car\.spring_rate belongs to a full-vehicle parameter file.*wheel_rate",
        ),
        (
            lambda t: t.replace("damper_motion_ratio = 0.8", "damper_motion_ratio = 0.8\nstrut_direction = [0, 0, 1]"),
            r"quarter_car\.strut_direction belongs to a full-vehicle parameter file",
        ),
        (
            lambda t: t + "\n[lca]\nmass = 4.5\n",
            r": lca belongs to a full-vehicle parameter file.*no lower control arm",
        ),
        (
            lambda t: t.replace("[quarter_car]", "[body]\nmass = 1300.0\n\n[quarter_car]"),
            r": body belongs to a full-vehicle parameter file.*quarter_car\.sprung_mass",
        ),
        (
            lambda t: t + "velocity = [-1.0, 1.0]\nforce = [-1000.0, 1000.0]\n",
            r"quarter_car\.damper\.velocity, quarter_car\.damper\.force: a force-velocity table belongs to model = "
            r"\"spline\"; this damper is \"linear\"",
        ),
        (lambda t: t.replace('model = "linear"', 'model = "spline"'), r"missing key 'quarter_car\.damper\.velocity'"),
        (
            lambda t: (
                t.replace('model = "linear"', 'model = "spline"') + "velocity = [1.0, -1.0]\nforce = [1.0, -1.0]\n"
            ),
            r"quarter_car\.damper\.velocity must increase strictly",
        ),
        (lambda t: t.replace('name = "test_car"', "name = 3"), r"name = 3 must be a string"),
        (lambda t: t.replace("[quarter_car.damper]\n", "[quarter_car.dampr]\n"), r"missing key 'quarter_car\.damper'"),
    ],
)
def test_bad_quarter_car_files_are_refused_naming_file_and_key(
    tmp_path: Path, edit: Callable[[str], str], message: str
) -> None:
    path = _write(tmp_path, "bad.toml", edit(MINIMAL))
    with pytest.raises(ParameterError, match=message) as refused:
        QuarterCarParameters.load(path)
    assert str(refused.value).startswith(f"{path}: ")


def test_file_shapes_and_corners_that_do_not_fit_are_refused(tmp_path: Path) -> None:
    quarter = _write(tmp_path, "quarter.toml", MINIMAL)
    with pytest.raises(ParameterError, match=r"quarter\.toml: a quarter-car parameter file.*a full vehicle needs"):
        VehicleParameters.load(quarter)
    with pytest.raises(ParameterError, match=r"quarter\.toml: a quarter-car parameter file"):
        vehicle_model("full-vehicle", VehicleBuildSettings(params_path=quarter))
    with pytest.raises(VehicleModelError, match=r"quarter\.toml: this quarter car stands on corner 'fr'.*'fl' was"):
        QuarterCarParameters.load(quarter, corner="fl")
    assert QuarterCarParameters.load(quarter, corner="fr").corner == "fr"
    with pytest.raises(VehicleBuildError, match="only a quarter car stands on one corner"):
        vehicle_model("full-vehicle", VehicleBuildSettings(corner="fl"))
    with pytest.raises(VehicleBuildError, match="corner 'left'"):
        VehicleBuildSettings(corner="left")
    with pytest.raises(ParameterError, match=r"missing\.toml: no such parameter file"):
        QuarterCarParameters.load(tmp_path / "missing.toml")
    assert math.isclose(QuarterCarParameters.load(corner="rl").sprung_mass, 1300.0 * 1.16 / 2.75 / 2.0, rel_tol=1e-12)
