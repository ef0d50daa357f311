"""The registry of component kinds (`nnfmu.kinds`): no kind is decided by an element-name prefix outside it, and a
new kind is one module's worth of declaration plus one registry line, picked up where the registry is used."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from nnfmu.kinds import (
    DAMPER,
    KINDS,
    ComponentKind,
    KindChannel,
    KindError,
    element_of_port,
    get_kind,
    kind_of,
    kind_of_rig,
)

PACKAGE = Path(__file__).resolve().parents[1] / "nnfmu"
# Kind decisions by name: a prefix test, a comparison with a kind's name, or a choice between kinds by a condition.
NAMES = "damper|bushing|engine_mount|mount"
BRANCHES = re.compile(
    rf"""startswith\(\s*f?["'](?:{NAMES})"""
    rf"""|[=!]=\s*["'](?:{NAMES})["']"""
    rf"""|["'](?:{NAMES})["']\s*[=!]="""
    rf"""|["'](?:{NAMES})["']\s+if\b"""
    rf"""|in\s+\(\s*["'](?:{NAMES})["']\s*,"""
)
# Files allowed to decide a kind by its name: the registry itself.
REGISTRY = PACKAGE / "kinds"
# Lines that match the pattern but decide no component kind (file, text in the line, why):
NOT_KIND_DECISIONS: tuple[tuple[str, str, str], ...] = ()

# An example kind, as its own module would declare it: an engine mount with one axial channel.
ENGINE_MOUNT = ComponentKind(
    name="engine_mount",
    prefix="engine_mount",
    description="a hydro mount between the engine and the body, along its axis",
    channels=(KindChannel("axial", "axial_force", "N", "axial_displacement", "m", "axial_velocity", "m/s"),),
    example="engine_mount_front",
)


@pytest.fixture
def engine_mount(monkeypatch: pytest.MonkeyPatch) -> ComponentKind:
    """The registry with the example kind added: the one line a new kind adds to `KINDS`."""
    monkeypatch.setitem(KINDS, ENGINE_MOUNT.name, ENGINE_MOUNT)
    return ENGINE_MOUNT


def test_no_kind_branching_by_name_outside_the_registry() -> None:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if REGISTRY in path.parents:
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            rel = str(path.relative_to(PACKAGE.parent))
            allowed = any(rel == f and text in line for f, text, _ in NOT_KIND_DECISIONS)
            if BRANCHES.search(line) and not allowed:
                found.append(f"{rel}:{number}: {line.strip()}")
    assert not found, "component kinds decided by name outside nnfmu/kinds (use the registry):\n" + "\n".join(found)


def test_the_pattern_catches_the_branches_it_forbids() -> None:
    for line in (
        'if element.startswith("damper"):',
        "if n.startswith('bushing_'):",
        'elif kind == "damper":',
        'if kind != "bushing":',
        'x = "damper_fl" if kind == "damper" else "bushing_fl_front"',
        'next(k for k in ("damper", "bushing") if e.startswith(k))',
    ):
        assert BRANCHES.search(line), line


def test_the_registered_kinds_name_their_elements_and_ports() -> None:
    assert list(KINDS) == ["damper", "bushing"]
    assert kind_of("damper_fl") is DAMPER and kind_of("damper") is DAMPER
    assert kind_of("bushing_fl_front").name == "bushing"
    assert kind_of("vehicle") is None and kind_of("controller") is None
    assert element_of_port("damper_fl_force") == "damper_fl"
    assert element_of_port("damper_force") == "damper"
    assert element_of_port("bushing_fl_front_radial_force") == "bushing_fl_front"
    assert element_of_port("bushing_fl_front_conical_torque") == "bushing_fl_front"
    assert element_of_port("damper_fl_velocity") is None
    assert kind_of_rig("bushing") is get_kind("bushing")
    with pytest.raises(KindError, match="'mount'.*damper, bushing"):
        get_kind("mount")
    with pytest.raises(KindError, match="unknown rig kind 'mount'"):
        kind_of_rig("mount")


def test_every_kind_declares_complete_channels_and_a_name_it_owns() -> None:
    for kind in KINDS.values():
        assert kind.channels and kind.owns(kind.example), kind.name
        for c in kind.channels:
            assert all((c.force, c.force_unit, c.position, c.position_unit, c.rate, c.rate_unit)), (kind.name, c)


def _car(fmus: dict[str, str]):
    """A virtual car of a vehicle and the components `fmus` (element -> FMU file, never opened), graphs named."""
    from nnfmu.cosim import Element, SystemStructure
    from nnfmu.workflows.system import VirtualSystem
    from nnfmu.workflows.vehicle_loop.system_files import VirtualCar

    elements = [Element("vehicle", "v.fmu"), *(Element(e, fmu) for e, fmu in fmus.items())]
    system = VirtualSystem.of(SystemStructure("car", elements, []))
    return VirtualCar(Path("s.ssd"), system, "vehicle", dict.fromkeys(fmus, Path("g.onnx")))


def test_an_example_kind_is_picked_up_by_the_registry_users(engine_mount: ComponentKind) -> None:
    from nnfmu.vehicle.dynamics.ports import component_channels

    assert kind_of("engine_mount_front") is engine_mount
    assert element_of_port("engine_mount_front_axial_force") == "engine_mount_front"
    assert component_channels("engine_mount_front") == [
        ("engine_mount_front_axial_force", "engine_mount_front_axial_displacement", "engine_mount_front_axial_velocity")
    ]
    car = _car({})
    assert car.kind("engine_mount_front") is engine_mount
    assert car.kind("damper_fl") is DAMPER


def test_a_name_of_no_kind_is_refused_by_the_vehicle_ports() -> None:
    from nnfmu.vehicle.dynamics.errors import VehicleModelError
    from nnfmu.vehicle.dynamics.ports import component_channels

    with pytest.raises(VehicleModelError, match="'engine_mount_front' is no element of a registered"):
        component_channels("engine_mount_front")


def test_the_vehicle_loop_tries_the_effects_a_kind_names(monkeypatch: pytest.MonkeyPatch) -> None:
    from dataclasses import replace

    from nnfmu.workflows.vehicle_loop.run import _candidates

    mount = replace(ENGINE_MOUNT, loop_effects=("gas_force",))
    car = _car({"engine_mount_front": "m.fmu", "damper_fl": "d.fmu"})
    found, _ = _candidates(car, ["body_acceleration_fl"], replay=None)  # type: ignore[arg-type]
    assert sorted(found) == ["body_acceleration_fl:sensor_offset", "damper_fl:gas_force"]
    monkeypatch.setitem(KINDS, mount.name, mount)
    found, _ = _candidates(car, ["body_acceleration_fl"], replay=None)  # type: ignore[arg-type]
    assert sorted(found) == [
        "body_acceleration_fl:sensor_offset",
        "damper_fl:gas_force",
        "engine_mount_front:gas_force",
    ]
