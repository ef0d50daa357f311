"""Road test: SSP systems for both vehicles, a linear damper against its exact monolithic counterpart, and the road
test with trained damper networks writing its reports and summary with finite metrics."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import onnx
import pytest

from nnfmu.cosim import CosimError
from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import open_system
from nnfmu.data.rigs import RigOptions, write_rig
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.vehicle.dynamics import LinearLaw, MonolithicSettings, simulate_monolithic
from nnfmu.vehicle.fmu import VehicleBuildSettings, vehicle_model
from nnfmu.workflows.characterise.settings import QUICK_SETTINGS
from nnfmu.workflows.roadtest import (
    BUSHING_MODELS,
    DAMPER_MODELS,
    RoadTestError,
    RoadTestResult,
    RoadTestSettings,
    SystemRun,
    actuator_inputs,
    build_vehicle,
    run_road_test,
    runs,
    write_system,
)
from nnfmu.workflows.roadtest.runs import COMPARED
from nnfmu.workflows.roadtest.systems import bushing_elements, damper_elements
from nnfmu.workflows.train import TrainRequest, train_from_file

DAMPING = 2500.0  # [N.s/m] of the linear damper
PERIOD = 1e-3  # [s] the rigs' sample period
# The full vehicle's compared channels in the short road test: one of each kind (damper, arm, body, wheel, and each
# bushing port the networks drive) instead of all 15 of `COMPARED`; each compared channel costs three plotted PNGs
# per model, which were 82 % of this module's time (189 plots).
FULL_VEHICLE_CHANNELS = (
    "damper_fl_force",
    "lca_fl_angle",
    "body_acceleration_fl",
    "spindle_fl_acceleration",
    "bushing_fl_front_axial_force",
    "bushing_fl_front_conical_torque",
)


def linear_damper(path: Path) -> Path:
    """An nnfmu step graph F = c v at the rigs' sample period (no state)."""
    onnx.save(linear_damper_graph(DAMPING, PERIOD, "linear_damper", (-2.0, 2.0)), path)
    return path


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Damper and bushing networks smoke-trained on short rig records (the bushing networks must have roughly the
    bushing's stiffness: the vehicle's stabilised ports hold each network's deviation from the linear bushing, and
    the truth physics' run uses the stabilisers fitted to the networks. After 3 epochs the radial network with its
    3 ms memory branch was 37 % off on its test split, its fitted damping a sixth of a 10-epoch network's, and the
    truth physics' full vehicle diverged within 0.1 s; after 10 it is 2.6 % off)."""
    folder = tmp_path_factory.mktemp("networks")
    lab, _ = write_rig("damper", folder / "damper.csv", RigOptions(duration=12.0, excitation="random"))
    rig, _ = write_rig("bushing", folder / "bushing.csv", RigOptions(duration=12.0, excitation="random"))
    return {
        p: train_from_file(
            data, TrainRequest(preset=p, restarts=1, max_epochs=epochs, hidden=(3,)), folder / f"{p}.onnx"
        ).path
        for data, presets, epochs in ((lab, DAMPER_MODELS, 3), (rig, BUSHING_MODELS, 10))
        for p in presets
    }


ROAD_LOG: list[str] = []  # what the road fixture's run logged


@pytest.fixture(scope="module")
def road(trained: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> RoadTestResult:
    """A short road test of both systems (the quarter car's default channels; the full vehicle a fraction of a second,
    `FULL_VEHICLE_CHANNELS`), each network FMU characterised on the quick series."""
    settings = RoadTestSettings(
        quarter_car=SystemRun(2.0),
        full_vehicle=SystemRun(0.3, channels=FULL_VEHICLE_CHANNELS),
        characterise=QUICK_SETTINGS,
    )
    return run_road_test(tmp_path_factory.mktemp("road"), trained, settings, log=ROAD_LOG.append)


@pytest.mark.slow
def test_ssds_of_both_systems_open_and_wire_every_network(road: RoadTestResult) -> None:
    shipped = {(s.system, m): s.ssds[m] for s in road.systems for m in DAMPER_MODELS}
    for (system, _), ssd in shipped.items():
        with open_system(ssd) as opened:
            elements = {e.name: e for e in opened.elements}
            assert sorted(elements) == sorted(["vehicle", *damper_elements(system), *bushing_elements(system)])
            driven = {
                (c.end_element, c.end_connector): (c.start_element, c.start_connector) for c in opened.connections
            }
            for damper in damper_elements(system):
                assert driven[("vehicle", f"{damper}_force")] == (damper, "force")
                assert driven[(damper, "velocity")] == ("vehicle", f"{damper}_velocity")
                assert elements[damper].parameters == {}  # the networks run at their FMU defaults
            for bushing_name in bushing_elements(system):
                for port in ("axial_force", "radial_force", "axial_torque", "conical_torque"):
                    assert driven[("vehicle", f"{bushing_name}_{port}")] == (bushing_name, port)
                assert driven[(bushing_name, "conical_rotation")] == ("vehicle", f"{bushing_name}_conical_rotation")


@pytest.mark.slow
def test_linear_damper_cosimulation_approaches_the_monolithic_solution(tmp_path: Path) -> None:
    damper = build_fmu(linear_damper(tmp_path / "linear.onnx"), BuildOptions(out=tmp_path / "linear.fmu"))
    vehicle = build_vehicle("quarter-car", tmp_path, 1e-4)
    ssd = write_system("quarter-car", vehicle, damper, None, tmp_path / "system")
    drive = generate_drive(DriveSettings(duration=1.0))
    with open_system(ssd) as system:
        result = cosimulate(system, drive, CosimSettings(step=1e-4)).measurement
    model = vehicle_model("quarter-car", VehicleBuildSettings())
    exact = simulate_monolithic(
        model,
        {"damper_force": LinearLaw(0.0, DAMPING)},
        actuator_inputs(model, drive),
        MonolithicSettings(sample_period=drive.sample_period),
    )
    for channel in ("damper_displacement", "damper_force"):
        cosim = np.interp(exact["time"], result.time, result[channel])
        error = np.sqrt(np.mean((cosim - exact[channel]) ** 2)) / np.sqrt(np.mean(exact[channel] ** 2))
        assert error < 0.03, (channel, error)


@pytest.mark.slow
def test_road_test_writes_reports_and_finite_thesis_metrics(road: RoadTestResult) -> None:
    result = road
    assert [s.system for s in result.systems] == ["quarter-car", "full-vehicle"]
    written = json.loads(result.summary.read_text())
    for system in written["systems"]:
        assert Path(system["report"]).is_file()
        models = {row["model"] for row in system["thesis_table"]}
        assert models == set(DAMPER_MODELS)
        # the full vehicle runs 0.3 s, too short for peaks of channels still settling; the quarter car runs 2 s
        keys = (
            ("peak_ratio", "valley_ratio", "rms_ratio", "damage_ratio", "amplitude_ratio_1hz", "mean_shift", "nrmse")
            if system["system"] == "quarter-car"
            else ("rms_ratio", "mean_shift", "nrmse")
        )
        for row in system["thesis_table"]:
            for key in keys:
                where = (system["system"], row["channel"], key)
                if key in row["not_meaningful"]:  # a metric the record is too short for: null, and why
                    assert row[key] is None and "too short" in row["not_meaningful"][key], where
                    continue
                assert row[key] is not None and math.isfinite(row[key]), where
        if system["system"] == "quarter-car":  # 2 s hold four periods of 2 Hz, not of 1 Hz
            assert all("amplitude_ratio_1hz" in row["not_meaningful"] for row in system["thesis_table"])
        for ssd in system["ssds"].values():
            with open_system(ssd):
                pass
        assert all(e["share_outside"] is not None for e in system["envelope"])
        # every network nnfmu trains carries its inputs' training band: each input's power above it is measured
        assert all(e["band_edge"] > 0 and 0 <= e["power_above_band"] <= 1 for e in system["envelope"])
        # each input beyond its envelope or above its band is a warning in the run's log, and only those
        flagged = {
            (e["run"], e["element"], e["port"]) for e in system["envelope"] if e["share_outside"] or e["above_band"]
        }
        warned = {
            (run, where.split(".")[0], where.split(".")[1].split(" ")[0])
            for line in ROAD_LOG
            if line.startswith(f"warning: {system['system']}, ")
            for run, where in [line.removeprefix(f"warning: {system['system']}, ").split(": ", 1)]
        }
        assert warned == flagged


@pytest.mark.slow
def test_each_system_report_links_the_characterisation_of_its_networks(road: RoadTestResult) -> None:
    """The quarter car's report links its two damper networks', the full vehicle's those and the merged bushing's;
    every link resolves to a characterisation report of the right kind."""
    expected = {"quarter-car": set(DAMPER_MODELS), "full-vehicle": {*DAMPER_MODELS, "lca-bushing"}}
    for system in road.systems:
        assert set(system.characterisations) == expected[system.system]
        html = system.report.read_text(encoding="utf-8")
        assert "<th>training band [Hz]</th><th>power above band [1]</th>" in html
        for network, found in system.characterisations.items():
            link = found.link(system.report)
            assert link == f"../../characterise/{network}/index.html"
            assert f'<a href="{link}">{network}: characterisation report</a>' in html
            kind = "bushing" if network == "lca-bushing" else "damper"
            assert f"{kind} characterisation of" in (system.report.parent / link).read_text(encoding="utf-8")
    bushing = road.out / "characterise" / "lca-bushing" / "dynamic_stiffness.csv"
    channels = {line.split(",")[0] for line in bushing.read_text(encoding="utf-8").splitlines()[1:]}
    assert channels == {"axial", "radial", "axial_rotation", "conical_rotation"}


@pytest.mark.slow
def test_the_error_budget_has_every_channel_and_the_coupling_costs_little(road: RoadTestResult) -> None:
    """Budget rows for every compared channel and damper model, all finite; with the truth physics as FMUs, the
    default coupling at 1 ms reproduces the quarter car's monolithic reference within 1 %: what is left of the
    total is the networks' (smoke-trained here, so far worse)."""
    written = json.loads(road.summary.read_text())
    for system in written["systems"]:
        channels = COMPARED["quarter-car"] if system["system"] == "quarter-car" else FULL_VEHICLE_CHANNELS
        assert [(r["channel"], r["model"]) for r in system["budget"]] == [
            (c, m) for m in DAMPER_MODELS for c in channels
        ]
        for row in system["budget"]:
            for key in ("nrmse_total", "nrmse_network", "nrmse_coupling", "damage_ratio"):
                where = (system["system"], row["channel"], key)
                if key in row["not_meaningful"]:  # too few rainflow cycles in a short run: null, and why
                    assert row[key] is None and "too short" in row["not_meaningful"][key], where
                    continue
                assert row[key] is not None and math.isfinite(row[key]), where
    quarter = {(r["channel"], r["model"]): r for r in written["systems"][0]["budget"]}
    for channel in ("damper_force", "damper_velocity", "body_acceleration", "spindle_acceleration"):
        row = quarter[(channel, "damper-hysteresis")]
        assert row["nrmse_coupling"] < 0.01, row
        assert row["nrmse_coupling"] < row["nrmse_total"], row


def test_missing_models_are_named(tmp_path: Path) -> None:
    with pytest.raises(RoadTestError, match="bushing-axial-force"):
        run_road_test(tmp_path, {p: tmp_path / "x.onnx" for p in DAMPER_MODELS}, RoadTestSettings(quarter_car=None))
    with pytest.raises(RoadTestError, match="not found"):
        run_road_test(tmp_path, {p: tmp_path / "x.onnx" for p in DAMPER_MODELS}, RoadTestSettings(full_vehicle=None))


@pytest.mark.slow
def test_a_failed_truth_physics_run_names_the_elements_fitted_to_the_networks(
    trained: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The truth physics' co-simulation runs on the stabilisers fitted to the bushing networks: when it fails (an
    under-trained radial network's fitted damping let it diverge within 0.1 s in CI), the error says so and names the
    fitted elements, not only the truth FMU that gave up."""
    real = runs._cosim

    def failing(system, drive, run):
        if system.fmu(bushing_elements("full-vehicle")[0]).name.startswith("truth"):
            raise CosimError("bushing_fl_front (truth-bushing.fmu): output 'axial_force' of sample 90 is inf")
        return real(system, drive, run)

    monkeypatch.setattr(runs, "_cosim", failing)
    settings = RoadTestSettings(
        quarter_car=None, full_vehicle=SystemRun(0.3, channels=FULL_VEHICLE_CHANNELS), characterise=None, fade_in=0.1
    )
    with pytest.raises(RoadTestError) as caught:
        run_road_test(tmp_path, trained, settings, log=lambda _: None)
    message = str(caught.value)
    assert (
        message.startswith("full-vehicle: the co-simulation with the truth physics") and "truth-bushing.fmu" in message
    )
    for fitted in ("axial_force", "radial_force", "axial_torque", "conical_torque"):
        assert f"; {fitted} " in f"; {message.split('networks (')[1]}", fitted
    assert " N/m, " in message and " N.m.s/rad" in message and "train the bushing networks further" in message
