"""The truth physics as step graphs and FMUs (the error budget's coupling column) against the rigs' own physics:
the bushing channels reproduce the rig's exact recursion, the damper an accurate solution of its valve ODE, and the
native FMUs their graphs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import pytest
from scipy.integrate import solve_ivp

from nnfmu.cosim.replay import replay_fmu
from nnfmu.data import Measurement
from nnfmu.data.rigs import BUSHING_CHANNELS, BushingChannelTruth, BushingParams, DamperParams, DamperTruth
from nnfmu.export.step_runner import run_step_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.workflows.roadtest.truth_graphs import TruthGraphError, bushing_truth_graph, damper_truth_graph

T = 1e-3
N = 2000
TIME = np.arange(N) * T


def _velocity(seed: int) -> np.ndarray:
    """A damper velocity [m/s] through both valve sides and past blow-off, from rest."""
    rng = np.random.default_rng(seed)
    v = 0.6 * np.sin(2 * np.pi * 3 * TIME) + 0.3 * np.sin(2 * np.pi * 17 * TIME + 1) + 0.05 * rng.normal(size=N)
    return v - v[0]


def _positions(seed: int) -> dict[str, np.ndarray]:
    """Random-walk deflections of every bushing channel within its vehicle range, from rest."""
    rng = np.random.default_rng(seed)
    scale = {"axial": 2e-5, "radial": 1e-5, "axial_rotation": 1e-3, "conical_rotation": 4e-4}
    walks = {key: np.cumsum(rng.normal(size=N)) * s for key, s in scale.items()}
    return {BUSHING_CHANNELS[key].position: walk - walk[0] for key, walk in walks.items()}


def _bushing_truths() -> dict[str, BushingChannelTruth]:
    params = BushingParams()
    return {key: BushingChannelTruth(getattr(params, key)) for key in BUSHING_CHANNELS}


@pytest.mark.slow
@pytest.mark.parametrize("effects", [("hysteresis", "seal_friction"), ("hysteresis", "seal_friction", "gas_force")])
def test_the_damper_graph_solves_the_valve_ode(effects: tuple[str, ...]) -> None:
    """Against a tight adaptive solution of F' = k_s (v - w(F)) with the velocity linear between samples (LSODA: the
    series stiffness makes the ODE stiff, so RK45 took 428 000 calls and three times the CPU for the same reference,
    1.05e-5 of the peak from the graph with either)."""
    truth = DamperTruth(DamperParams(), effects)
    v = _velocity(1)
    x = np.cumsum(v) * T
    got = run_step_graph(
        damper_truth_graph(truth, T), {"velocity": v} | ({"displacement": x} if "gas_force" in effects else {})
    )["force"]
    solved = solve_ivp(
        lambda t, z: truth.derivatives(t, z, 0.0, float(np.interp(t, TIME, v))),
        (0.0, TIME[-1]),
        truth.initial_state(),
        t_eval=TIME,
        method="LSODA",
        rtol=1e-10,
        atol=1e-8,
        max_step=1e-4,
    )
    want = truth.force(solved.y.T, x, v, np.zeros(N))
    assert np.max(np.abs(got - want)) < 1e-4 * np.max(np.abs(want))
    assert np.ptp(want) > 3000  # both valve sides and blow-off are crossed


def test_the_bushing_graph_is_the_rigs_exact_recursion() -> None:
    truths = _bushing_truths()
    positions = _positions(2)
    got = run_step_graph(bushing_truth_graph(truths, T), positions)
    for key, truth in truths.items():
        channel = BUSHING_CHANNELS[key]
        want, _ = truth.simulate(T, positions[channel.position])
        assert np.max(np.abs(got[channel.force] - want)) <= 1e-9 * np.max(np.abs(want)), key


def test_the_bushing_graph_starts_relaxed_where_it_stands() -> None:
    """A car starts on deflected bushings: the first sample takes no position change (as the rig's recursion and the
    monolithic reference's rest state), so a run from a deflection is a run from zero shifted by the elastic law."""
    truths = _bushing_truths()
    start = {"axial": 1e-4, "radial": -5e-6, "axial_rotation": 2e-3, "conical_rotation": -1e-3}
    positions = {BUSHING_CHANNELS[k].position: x + start[k] for k, x in zip(BUSHING_CHANNELS, _positions(5).values())}
    got = run_step_graph(bushing_truth_graph(truths, T), positions)
    for key, truth in truths.items():
        channel = BUSHING_CHANNELS[key]
        want, _ = truth.simulate(T, positions[channel.position])
        assert abs(got[channel.force][0] - truth.elastic_force(start[key])) <= 1e-12 * abs(want[0]), key
        assert np.max(np.abs(got[channel.force] - want)) <= 1e-9 * np.max(np.abs(want)), key


@pytest.mark.slow
@pytest.mark.win64  # the truth graphs' C compiled by MinGW-w64 too (-Werror): no test of tests/fmu/ builds them
def test_the_native_fmus_are_their_graphs(tmp_path: Path) -> None:
    truth = DamperTruth(DamperParams(), ("hysteresis", "seal_friction"))
    cases = {
        "damper": (damper_truth_graph(truth, T), {"velocity": _velocity(3)}),
        "bushing": (bushing_truth_graph(_bushing_truths(), T), _positions(4)),
    }
    for name, (graph, inputs) in cases.items():
        onnx.save(graph, tmp_path / f"{name}.onnx")
        fmu = build_fmu(tmp_path / f"{name}.onnx", BuildOptions(out=tmp_path / f"{name}.fmu"))
        units = {p: "m/s" if p == "velocity" else ("rad" if "rotation" in p else "m") for p in inputs}
        replayed = replay_fmu(fmu, Measurement(TIME, inputs, units, source=name))
        for output, want in run_step_graph(graph, inputs).items():
            assert np.max(np.abs(replayed[output] - want)) <= 1e-12 * np.max(np.abs(want)), (name, output)


def test_unsupported_effects_are_named() -> None:
    with pytest.raises(TruthGraphError, match="temperature"):
        damper_truth_graph(DamperTruth(DamperParams(), ("hysteresis", "temperature")), T)
    with pytest.raises(TruthGraphError, match="hysteresis"):
        damper_truth_graph(DamperTruth(DamperParams(), ("seal_friction",)), T)
    with pytest.raises(TruthGraphError, match="lateral"):
        bushing_truth_graph({"lateral": _bushing_truths()["axial"]}, T)
