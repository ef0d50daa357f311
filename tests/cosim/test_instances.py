"""FMU instances kept in a pool between co-simulations: a reset instance gives the same result bit for bit as a freshly
opened one (parameter values set by the earlier run do not leak into the next), and only instances of runs that went
well are kept, at most the pool's capacity."""

from __future__ import annotations

import dataclasses

import numpy as np
import onnx
import pytest
from cosim_system_helpers import drive

from nnfmu.cosim.drive_inputs import DriveInputError
from nnfmu.cosim.instances import InstancePool
from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import SystemStructure, connect_by_name, open_system, write_ssd
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.workflows.campaign.quarter_car import NO_FILTER, build_quarter_car_system

H = 1e-3  # [s]
DRIVE = drive(0.5, 0.5e-3, corner="fl")


@pytest.fixture(scope="module")
def system(tmp_path_factory: pytest.TempPathFactory) -> SystemStructure:
    paths = build_quarter_car_system(tmp_path_factory.mktemp("quarter-car"), {"linear": 2400.0}, step=H)
    with open_system(paths["system"]) as opened:
        yield opened


def with_damper_parameters(system: SystemStructure, **values: float) -> SystemStructure:
    elements = [
        dataclasses.replace(e, parameters=dict(e.parameters) | values) if e.name == "damper" else e
        for e in system.elements
    ]
    return dataclasses.replace(system, elements=elements)


def channels(result) -> dict[str, np.ndarray]:
    return {name: result.measurement[name] for name in result.measurement.names}


def assert_identical(a, b) -> None:
    assert a.keys() == b.keys()
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_a_reset_instance_runs_like_a_fresh_one(system):
    settings = CosimSettings(step=H)
    fresh = channels(cosimulate(system, DRIVE, settings))
    pool = InstancePool()
    try:
        doubled = cosimulate(with_damper_parameters(system, output_gain=2.0), DRIVE, settings, pool=pool)
        assert (pool.opened, pool.reused, len(pool)) == (2, 0, 2)
        assert not np.allclose(channels(doubled)["damper_force"], fresh["damper_force"])  # the gain took effect
        again = channels(cosimulate(system, DRIVE, settings, pool=pool))  # the gain is back at its start value
        assert (pool.opened, pool.reused, len(pool)) == (2, 2, 2)
        assert_identical(again, fresh)
    finally:
        pool.close()
    assert len(pool) == 0


def test_a_pythonfmu_fmi3_damper_resets_too(tmp_path):
    """The other backend and FMI 3's reset: the damper as a pythonfmu FMI 3 FMU beside the native vehicle."""
    paths = build_quarter_car_system(tmp_path / "native", {"linear": 2400.0}, step=H)
    onnx.save(linear_damper_graph(2400.0), tmp_path / "damper.onnx")
    damper = build_fmu(
        tmp_path / "damper.onnx", BuildOptions(out=tmp_path / "damper.fmu", backend="pythonfmu", fmi_version=3)
    )
    ssd = write_ssd(
        connect_by_name(
            "quarter car", ("vehicle", paths["vehicle"]), {"damper": damper}, tmp_path, {"damper": NO_FILTER}
        ),
        tmp_path / "system.ssd",
    )
    with open_system(ssd) as system:
        fresh = channels(cosimulate(system, DRIVE, CosimSettings(step=H)))
        pool = InstancePool()
        try:
            cosimulate(with_damper_parameters(system, output_gain=2.0), DRIVE, CosimSettings(step=H), pool=pool)
            again = channels(cosimulate(system, DRIVE, CosimSettings(step=H), pool=pool))
            assert pool.reused == 2
        finally:
            pool.close()
    assert_identical(again, fresh)


def test_instances_of_a_failed_run_are_not_kept(system):
    pool = InstancePool()
    try:
        cosimulate(system, DRIVE, CosimSettings(step=H), pool=pool)
        with pytest.raises(DriveInputError, match="outside the drive"):
            cosimulate(system, DRIVE, CosimSettings(step=H, stop_time=2.0), pool=pool)  # the drive ends at 0.5 s
        assert (pool.opened, pool.reused, len(pool)) == (2, 2, 0)
        cosimulate(system, DRIVE, CosimSettings(step=H), pool=pool)
        assert (pool.opened, len(pool)) == (4, 2)
    finally:
        pool.close()


def test_the_pool_keeps_at_most_its_capacity(system):
    pool = InstancePool(capacity=1)
    try:
        cosimulate(system, DRIVE, CosimSettings(step=H), pool=pool)
        assert len(pool) == 1
    finally:
        pool.close()
    with pytest.raises(ValueError, match="capacity"):
        InstancePool(capacity=-1)


def test_a_rebuilt_fmu_is_opened_anew(tmp_path):
    paths = build_quarter_car_system(tmp_path, {"linear": 2400.0}, step=H)
    pool = InstancePool()
    try:
        with open_system(paths["system"]) as system:
            cosimulate(system, DRIVE, CosimSettings(step=H), pool=pool)
            build_quarter_car_system(tmp_path, {"linear": 3000.0}, step=H)  # same paths, new files
            cosimulate(system, DRIVE, CosimSettings(step=H), pool=pool)
        assert pool.opened == 4
    finally:
        pool.close()
