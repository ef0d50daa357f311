"""Precision that survives the user's master (docs/masters.md): an nnfmu damper FMU on a vehicle nnfmu did not write
(the vendor quarter car: inputs held over the step, no interpolation), coupled by fmpy alone and by libcosim.

A network FMU samples at its trained period T, but between samples it evaluates its graph on the inputs of the
moment and its interpolated state, so a smaller communication step shrinks the coupling error as it does for any
continuous model. The truth-law damper as an nnfmu FMU isolates the coupling (its own error is nil): at h = T/10
its force and the body acceleration are an order of magnitude closer to the monolithic reference than at h = T
(before, the FMU held its output for T and h = T/10 was no better than h = T). A small trained network then stays
within 1.5 times its own open-loop error at h = T/10 in every master.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from plain_coupling import libcosim_loop, monolithic, nrmse, plain_loop, replay
from vendor_fmu import build_vendor_quarter_car

from nnfmu.data.rigs import DamperTruth, RigOptions, write_rig
from nnfmu.fmu.build import build_fmu, build_fmu_from_model
from nnfmu.fmu.options import BuildOptions
from nnfmu.workflows.roadtest.truth_graphs import damper_truth_graph
from nnfmu.workflows.train import TrainRequest, train_from_file

pytestmark = pytest.mark.slow

T = 1e-3  # the damper FMUs' sample period [s]
DURATION = 1.5  # s of road, the pothole at 1 s
REFERENCE_STEP = 2e-4  # RK4 step of the monolithic reference (1.5e-6 relative from the 1e-4 s solution)
TRUTH = DamperTruth(effects=("hysteresis", "seal_friction"))  # the dyno's damper less its fixture's mass


@pytest.fixture(scope="module")
def reference() -> np.ndarray:
    return monolithic(TRUTH, DURATION, REFERENCE_STEP)


@pytest.fixture(scope="module")
def car(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_vendor_quarter_car(tmp_path_factory.mktemp("vendor"))


def error(got: np.ndarray, h: float, reference: np.ndarray, first: int = 0) -> np.ndarray:
    """NRMSE of damper force and body acceleration, `got` (row k at t = (k + first) h) against the reference on
    their common time points."""
    if h >= REFERENCE_STEP:
        return nrmse(got, reference[:: round(h / REFERENCE_STEP), :2][first:])
    every = round(REFERENCE_STEP / h)
    rows = np.arange(first, first + len(got))
    keep = rows % every == 0
    return nrmse(got[keep], reference[rows[keep] // every, :2])


def test_a_smaller_step_shrinks_the_coupling_error_of_a_sampled_fmu(car: Path, reference, tmp_path: Path) -> None:
    damper = build_fmu_from_model(damper_truth_graph(TRUTH, T), BuildOptions(out=tmp_path / "truth.fmu"))
    errors = {
        (scheme, h): error(plain_loop(car, damper, DURATION, h, scheme), h, reference)
        for scheme in ("gauss-seidel", "jacobi")
        for h in (T, T / 10)
    }
    for scheme in ("gauss-seidel", "jacobi"):
        at_t, at_tenth = errors[(scheme, T)], errors[(scheme, T / 10)]
        assert np.all(at_t > 0.01), (scheme, at_t)  # the coupling's share at h = T is real (1-6 %)
        assert np.all(at_tenth < 0.2 * at_t), (scheme, at_t, at_tenth)  # first order in h, as a continuous model
    assert np.all(errors[("gauss-seidel", T / 10)] < 0.005)
    libcosim = error(libcosim_loop(car, damper, DURATION, T / 10), T / 10, reference, first=1)
    assert np.all(libcosim < 0.2 * errors[("jacobi", T)]), libcosim


@pytest.fixture(scope="module")
def network(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small hysteresis network trained on a 12 s random dyno record (the fixture's 2 kg taken out), as a FMU."""
    folder = tmp_path_factory.mktemp("network")
    dyno, _ = write_rig("damper", folder / "dyno.csv", RigOptions(duration=12.0, excitation="random", noise=0.5))
    onnx = train_from_file(
        dyno,
        TrainRequest(preset="damper-hysteresis", restarts=1, max_epochs=80, hidden=(8,), moving_mass=2.0),
        folder / "damper.onnx",
    ).path
    return build_fmu(onnx, BuildOptions(out=folder / "damper.fmu", platforms=("linux64",)))


def test_a_network_in_plain_masters_stays_within_its_own_error(car: Path, network: Path, reference) -> None:
    """Open loop: the network replayed at h = T on the reference car's own damper motion (fmpy alone); coupled:
    the network on the vendor car at h = T/10 in a Gauss-Seidel and a Jacobi fmpy loop and in libcosim."""
    sampled = reference[:: round(T / REFERENCE_STEP)]
    own = nrmse(replay(network, sampled[:, 2], sampled[:, 3], T), sampled[:, 0])
    assert 0.002 < own < 0.15  # a real, imperfect network
    h = T / 10
    coupled = {
        "gauss-seidel": error(plain_loop(car, network, DURATION, h, "gauss-seidel"), h, reference),
        "jacobi": error(plain_loop(car, network, DURATION, h, "jacobi"), h, reference),
        "libcosim": error(libcosim_loop(car, network, DURATION, h), h, reference, first=1),
    }
    for master, errors in coupled.items():
        assert np.all(errors <= 1.5 * own), (master, errors, own)
