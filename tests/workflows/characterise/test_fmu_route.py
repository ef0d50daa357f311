"""The standard tests through an FMU whose law is known: a linear spring-damper bushing against the closed form, the
rigs' truth damper and bushing (as step-graph FMUs) against the truth law run directly and finely; the CLI with a
dyno record's sine series beside; and the refusals of what no test fits."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import onnx
import pytest
from plain_master import plain_replay, port_names  # tests/cosim, put on the path by tests/workflows/conftest.py
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.component import Component, Port
from nnfmu.data import Measurement
from nnfmu.data.rigs import BushingChannelTruth, BushingParams, BushingRig, DamperDyno, DamperParams, DamperTruth
from nnfmu.data.rigs.bushing_rig import UNITS as BUSHING_UNITS
from nnfmu.data.rigs.bushing_rig import run_bushing_rig
from nnfmu.data.rigs.damper_rig import run_damper_dyno
from nnfmu.data.save import save_measurement
from nnfmu.export.graph import GraphBuilder
from nnfmu.fmu.build import build_fmu_from_model
from nnfmu.fmu.native.toolchain import host_binaries_only
from nnfmu.fmu.options import BuildOptions
from nnfmu.workflows.characterise import (
    BushingTestSettings,
    CharacteriseError,
    CharacteriseSettings,
    DamperTestSettings,
    characterise,
)
from nnfmu.workflows.characterise.bushing import channel_inputs, channel_plan, read_channel
from nnfmu.workflows.characterise.damper import damper_inputs, damper_tests, read_damper
from nnfmu.workflows.characterise.model import TestRun as ModelRun  # not "Test...": pytest would collect it
from nnfmu.workflows.characterise.model import model_under_test
from nnfmu.workflows.characterise.signals import SineTest, sine_motion
from nnfmu.workflows.characterise.truth import bushing_truth_runs, damper_truth_runs
from nnfmu.workflows.roadtest.truth_graphs import bushing_truth_graph, damper_truth_graph

T = 1e-3
K, C = 1.0e6, 800.0  # the linear bushing [N/m], [N.s/m]
DAMPER_EFFECTS = ("hysteresis", "seal_friction", "gas_force")
DAMPER = DamperTestSettings(peak_velocities=(0.05, 0.5, 1.5), stroke=0.01, settle_cycles=1)


def _linear_bushing() -> onnx.ModelProto:
    """axial_force = K·axial_displacement + C·axial_velocity, sampled every T."""
    graph = GraphBuilder(reserved=["axial_displacement", "axial_velocity", "axial_force"])
    spring = graph.node("Mul", ["axial_displacement", graph.constant("k", np.array([K]))], "spring")
    damper = graph.node("Mul", ["axial_velocity", graph.constant("c", np.array([C]))], "damper")
    graph.output(graph.node("Add", [spring, damper], "sum"), "axial_force")
    model = graph.model(
        "linear_bushing", "k x + c v", [("axial_displacement", 1), ("axial_velocity", 1)], [("axial_force", 1)]
    )
    Component(
        "linear_bushing",
        [Port("axial_displacement", "m"), Port("axial_velocity", "m/s")],
        [Port("axial_force", "N")],
        sample_period=T,
    ).attach_to(model)
    return model


@pytest.fixture(scope="module")
def models(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The linear bushing as an ONNX file; the truth damper and truth bushing as native FMUs."""
    folder = tmp_path_factory.mktemp("models")
    onnx.save(_linear_bushing(), str(folder / "linear_bushing.onnx"))
    with host_binaries_only():
        damper = damper_truth_graph(DamperTruth(DamperParams(), DAMPER_EFFECTS), T, substeps=4)
        build_fmu_from_model(damper, BuildOptions(out=folder / "damper.fmu"))
        bushing = bushing_truth_graph({"axial": BushingChannelTruth(BushingParams().axial)}, T)
        build_fmu_from_model(bushing, BuildOptions(out=folder / "bushing.fmu"))
    return {
        "linear": folder / "linear_bushing.onnx",
        "damper": folder / "damper.fmu",
        "bushing": folder / "bushing.fmu",
    }


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8") as stream:
        return list(csv.DictReader(stream))


@pytest.mark.slow
def test_the_linear_bushing_from_its_onnx_has_the_closed_form_stiffness(models: dict[str, Path], tmp_path: Path):
    settings = CharacteriseSettings(
        bushing=BushingTestSettings(frequencies=(1.0, 10.0, 100.0), settle_cycles=1, quasi_static_frequency=1.0)
    )
    report = characterise(models["linear"], tmp_path / "out", settings=settings, log=lambda _: None)
    assert report.kind == "bushing" and report.index.is_file()
    rows = _rows(tmp_path / "out" / "dynamic_stiffness.csv")
    assert len(rows) == 9 and {"amplitude [m]", "dynamic_stiffness [N/m]", "loss_angle [deg]"} <= set(rows[0])
    for row in rows:
        omega = 2 * math.pi * float(row["frequency [Hz]"])
        assert float(row["dynamic_stiffness [N/m]"]) == pytest.approx(math.hypot(K, C * omega), rel=1e-6)
        assert float(row["loss_angle [deg]"]) == pytest.approx(math.degrees(math.atan(C * omega / K)), abs=1e-5)
    loop = _rows(tmp_path / "out" / "quasi_static_loop.csv")
    assert {"axial_displacement [m]", "axial_force [N]"} == set(loop[0])


def test_a_point_above_the_band_the_onnx_carries_is_outside_through_its_fmu(tmp_path: Path) -> None:
    """The band rides in the component description from the ONNX file into the FMU the test runs: the report names
    the 100 Hz points above it and lists the band."""
    model = _linear_bushing()
    component = Component.from_onnx(model)
    edges = {"axial_displacement": 10.0, "axial_velocity": 20.0}
    component.metadata = {"training_band": {"power_share": 0.99, "upper_edge_Hz": edges}}
    component.attach_to(model)
    onnx.save(model, str(tmp_path / "banded.onnx"))
    settings = CharacteriseSettings(
        bushing=BushingTestSettings(frequencies=(1.0, 10.0, 100.0), settle_cycles=1, quasi_static_frequency=1.0),
        figures=False,
    )
    characterise(tmp_path / "banded.onnx", tmp_path / "out", settings=settings, log=lambda _: None)
    for row in _rows(tmp_path / "out" / "dynamic_stiffness.csv"):
        above = float(row["frequency [Hz]"]) > 20.0
        expected = "outside: 100 Hz above the training band (20 Hz, axial_velocity)" if above else "inside"
        assert row["training_envelope"] == expected, row
    html = (tmp_path / "out" / "index.html").read_text(encoding="utf-8")
    assert "3 of 9 test points drive an input beyond" in html
    assert "power below it in the training record): axial_displacement 10 Hz, axial_velocity 20 Hz." in html


def _sine_record(path: Path, stiffness: float, amplitudes: tuple[float, ...], frequency: float = 2.0) -> Path:
    """A record of the law stiffness·x + C·v over a sine series: 0.3 s at rest, then each amplitude for 4 cycles."""
    rest = np.zeros(300)
    cycle = np.arange(round(4 / (frequency * T))) * T
    x = np.concatenate([rest, *(p for a in amplitudes for p in (a * np.sin(2 * np.pi * frequency * cycle), rest))])
    v = np.concatenate(
        [
            rest,
            *(p for a in amplitudes for p in (a * 2 * np.pi * frequency * np.cos(2 * np.pi * frequency * cycle), rest)),
        ]
    )
    channels = {"axial_displacement": x, "axial_velocity": v, "axial_force": stiffness * x + C * v}
    save_measurement(
        Measurement(
            np.arange(x.size) * T, channels, {"axial_displacement": "m", "axial_velocity": "m/s", "axial_force": "N"}
        ),
        path,
    )
    return path


def test_each_measured_point_is_judged_against_the_own_error_the_onnx_carries(tmp_path: Path) -> None:
    """The own error rides in the component description from the ONNX file into the FMU the test runs. The record's
    spring is 1 % stiffer than the model's, so its first-harmonic force is off by 0.01·K·a, an RMS of 0.01·K·a/√2:
    7.1 N at 1 mm and 14.1 N at 2 mm, against an own error of 10 N: the first within it, the second not."""
    model = _linear_bushing()
    component = Component.from_onnx(model)
    component.metadata = {
        "feature_spec": {"output": "axial_force"},
        "metrics": {"test": {"rms_error": 10.0, "nrmse": 0.01}},
    }
    component.attach_to(model)
    onnx.save(model, str(tmp_path / "judged.onnx"))
    record = _sine_record(tmp_path / "rig.csv", 1.01 * K, (1e-3, 2e-3))
    result = CliRunner().invoke(
        app, ["characterise", str(tmp_path / "judged.onnx"), "--measured", str(record), "--out", str(tmp_path / "out")]
    )
    assert result.exit_code == 0, result.output
    assert "within the network's own error: 1 of 2 test points inside its envelope" in result.output
    rows = _rows(tmp_path / "out" / "dynamic_stiffness.csv")
    assert [float(r["amplitude [m]"]) for r in rows] == pytest.approx([1e-3, 2e-3], rel=1e-6)
    for row in rows:
        expected = 0.01 * K * float(row["amplitude [m]"]) / math.sqrt(2)
        assert float(row["harmonic_force_deviation_rms [N]"]) == pytest.approx(expected, rel=1e-3)
        assert float(row["deviation_over_own_error [1]"]) == pytest.approx(expected / 10.0, rel=1e-3)
    assert [r["within_own_error"] for r in rows] == ["yes", "no"]
    html = (tmp_path / "out" / "index.html").read_text(encoding="utf-8")
    assert "axial_force 10 N RMS (NRMSE 1 %)" in html and "1 of 2 test points inside the training envelope" in html


def test_without_an_own_error_the_deviations_are_not_judged_and_the_report_says_so(tmp_path: Path) -> None:
    onnx.save(_linear_bushing(), str(tmp_path / "plain.onnx"))
    record = _sine_record(tmp_path / "rig.csv", 1.01 * K, (1e-3,))
    report = characterise(tmp_path / "plain.onnx", tmp_path / "out", record, log=lambda _: None)
    assert report.within_own_error is None
    (row,) = _rows(tmp_path / "out" / "dynamic_stiffness.csv")
    assert float(row["harmonic_force_deviation_rms [N]"]) > 0 and "within_own_error" not in row
    html = (tmp_path / "out" / "index.html").read_text(encoding="utf-8")
    assert "The network carries no own error" in html and "not carried" in html


def test_the_truth_damper_fmu_reproduces_the_truth_law(models: dict[str, Path], tmp_path: Path) -> None:
    """Forces at peak velocity within 0.3 %, gas force and friction within 0.1 N of the law run directly (0.1 ms)."""
    characterise(models["damper"], tmp_path / "out", settings=CharacteriseSettings(damper=DAMPER), log=print)
    rows = _rows(tmp_path / "out" / "characteristic.csv")
    truth = read_damper(damper_truth_runs(DamperTruth(DamperParams(), DAMPER_EFFECTS), damper_tests(DAMPER, [None]), T))
    assert [float(r["peak_velocity [m/s]"]) for r in rows] == pytest.approx(DAMPER.peak_velocities, rel=1e-9)
    for row, point in zip(rows, truth.points):
        assert float(row["rebound_force [N]"]) == pytest.approx(point.rebound_force, rel=3e-3)
        assert float(row["jounce_force [N]"]) == pytest.approx(point.jounce_force, rel=3e-3)
        assert float(row["jounce_force [N]"]) < 0 < float(row["rebound_force [N]"])
    (gas,) = _rows(tmp_path / "out" / "gas_friction.csv")
    assert float(gas["gas_force [N]"]) == pytest.approx(truth.gas_friction[None].gas_force, abs=0.1)
    assert float(gas["friction [N]"]) == pytest.approx(truth.gas_friction[None].friction, abs=0.1)
    assert len(_rows(tmp_path / "out" / "work_diagrams.csv")) > 100


def _plain_runs(fmu: Path, tests: list[SineTest], inputs: dict[str, tuple[str, str]], output: str) -> list[ModelRun]:
    """Each test's sine replayed on `fmu` by fmpy alone at its defaults (tests/cosim/plain_master.py), as runs the
    characterisation's readers take; `inputs` says which signal drives each FMU input, as the characterisation does."""
    runs = []
    for test in tests:
        motion = sine_motion(test, T)
        signals = {"position": motion.position, "rate": motion.rate, "zero": np.zeros_like(motion.time)}
        drive = {name: signals[signal] for name, (signal, _) in inputs.items()}
        runs.append(ModelRun(test, motion, plain_replay(fmu, drive, T, output)))
    return runs


def test_the_characteristic_is_what_a_plain_fmpy_loop_gets_from_the_fmu(models: dict[str, Path], tmp_path: Path):
    """The characteristic's forces equal those read from the same sines replayed by fmpy alone at the FMU's defaults
    (tests/cosim/plain_master.py: no nnfmu code in the loop), so the report states what a user's master gets."""
    characterise(models["damper"], tmp_path / "out", settings=CharacteriseSettings(damper=DAMPER), log=lambda _: None)
    rows = _rows(tmp_path / "out" / "characteristic.csv")
    with model_under_test(models["damper"]) as model:
        inputs = damper_inputs(model.kind, 293.15)
    assert set(inputs) == set(port_names(models["damper"], "input"))
    runs = _plain_runs(models["damper"], damper_tests(DAMPER, [None]), inputs, "force")
    plain = read_damper(runs)
    for row, point in zip(rows, plain.points, strict=True):
        assert float(row["rebound_force [N]"]) == pytest.approx(point.rebound_force, rel=1e-9)
        assert float(row["jounce_force [N]"]) == pytest.approx(point.jounce_force, rel=1e-9)
    (gas,) = _rows(tmp_path / "out" / "gas_friction.csv")
    assert float(gas["gas_force [N]"]) == pytest.approx(plain.gas_friction[None].gas_force, rel=1e-9, abs=1e-9)
    assert float(gas["friction [N]"]) == pytest.approx(plain.gas_friction[None].friction, rel=1e-9, abs=1e-9)


def test_the_truth_bushing_fmu_reproduces_the_truth_law(models: dict[str, Path], tmp_path: Path) -> None:
    """|K*| within 0.5 % and the loss angle within 0.05 deg of the channel's law run directly at a tenth of T."""
    settings = BushingTestSettings(
        frequencies=(2.0, 20.0), amplitude_fractions=(0.2, 1.0), settle_cycles=2, quasi_static_frequency=1.0
    )
    characterise(models["bushing"], tmp_path / "out", settings=CharacteriseSettings(bushing=settings), log=print)
    rows = _rows(tmp_path / "out" / "dynamic_stiffness.csv")
    reach = 2.5e-3  # the axial channel's vehicle range [m]
    tests = [SineTest(a * reach, f, 2) for a in (0.2, 1.0) for f in (2.0, 20.0)]
    truth = read_channel("axial", bushing_truth_runs(BushingChannelTruth(BushingParams().axial), tests, T))
    for row, point in zip(rows, truth, strict=True):
        assert float(row["dynamic_stiffness [N/m]"]) == pytest.approx(point.dynamic_stiffness, rel=5e-3)
        assert float(row["loss_angle [deg]"]) == pytest.approx(point.loss_angle, abs=0.05)
    assert [float(r["amplitude [m]"]) for r in rows] == pytest.approx([t.amplitude for t in tests], rel=1e-9)
    # the progressive spring (k3 x^3) at the full vehicle range stiffens the channel by a fifth at 2 Hz
    assert float(rows[2]["dynamic_stiffness [N/m]"]) > 1.15 * float(rows[0]["dynamic_stiffness [N/m]"])


def test_the_dynamic_stiffness_is_what_a_plain_fmpy_loop_gets_from_the_fmu(models: dict[str, Path], tmp_path: Path):
    """|K*| and loss angle equal those read from the same sines replayed by fmpy alone at the FMU's defaults."""
    settings = BushingTestSettings(frequencies=(2.0, 20.0), amplitude_fractions=(0.2, 1.0), settle_cycles=2)
    characterise(models["bushing"], tmp_path / "out", settings=CharacteriseSettings(bushing=settings), log=print)
    rows = _rows(tmp_path / "out" / "dynamic_stiffness.csv")
    with model_under_test(models["bushing"]) as model:
        (channel,) = model.kind.channels
        inputs = channel_inputs(model.kind, channel)
        plan = channel_plan(channel, settings)
    assert set(inputs) == set(port_names(models["bushing"], "input"))
    runs = _plain_runs(models["bushing"], plan.stiffness, inputs, channel.force)
    for row, point in zip(rows, read_channel(channel.key, runs), strict=True):
        assert float(row["dynamic_stiffness [N/m]"]) == pytest.approx(point.dynamic_stiffness, rel=1e-9)
        assert float(row["loss_angle [deg]"]) == pytest.approx(point.loss_angle, abs=1e-8)


def _dyno_record(path: Path, effects: tuple[str, ...]) -> Path:
    """A dyno's sine series (no random part) of the truth damper, recorded with the dyno's sensor noise."""
    dyno = DamperDyno(peak_velocities=(0.05, 0.5, 1.5), max_amplitude=0.01)
    rate, n = 1 / T, 9000
    time, channels, _ = run_damper_dyno(DamperParams(), effects, dyno, rate, n, "sine", 1.0, 4)
    units = {"displacement": "m", "velocity": "m/s", "force": "N"}
    save_measurement(Measurement(time, channels, units, source=str(path)), path)
    return path


def test_the_cli_puts_the_measured_characteristic_beside_the_model(models: dict[str, Path], tmp_path: Path) -> None:
    record = _dyno_record(tmp_path / "dyno.csv", DAMPER_EFFECTS)
    out = tmp_path / "report"
    result = CliRunner().invoke(
        app, ["characterise", str(models["damper"]), "--measured", str(record), "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    rows = _rows(out / "characteristic.csv")
    assert [round(float(r["peak_velocity [m/s]"]), 2) for r in rows] == [0.05, 0.5, 1.5]
    for row in rows:  # the same law: the dyno's noise (10 N rms) averaged over its cycles
        assert abs(float(row["rebound_deviation [N]"])) < 15 and abs(float(row["jounce_deviation [N]"])) < 15
        assert float(row["rebound_deviation [N]"]) == pytest.approx(
            float(row["rebound_force [N]"]) - float(row["measured_rebound_force [N]"]), abs=1e-6
        )
    html = (out / "index.html").read_text(encoding="utf-8")
    # the deviation columns shown (headers break at spaces to fit a 1280 px page) and the headline above them
    assert "<th>measured rebound force [N]</th>" in html and "<th>rebound deviation [N]</th>" in html
    assert "Largest deviation per column: rebound deviation " in html and "characteristic.png" in html
    assert "<th>training envelope</th>" in html
    assert (out / "measured_work_diagrams.csv").is_file()


def test_a_record_without_sine_tests_is_refused(models: dict[str, Path], tmp_path: Path) -> None:
    time = np.arange(3000) * T
    rng = np.random.default_rng(0)
    walk = np.cumsum(rng.normal(size=time.size)) * 1e-4
    record = tmp_path / "random.csv"
    save_measurement(
        Measurement(time, {"displacement": walk, "force": 1e4 * walk}, {"displacement": "m", "force": "N"}), record
    )
    with pytest.raises(CharacteriseError, match=r"random\.csv: no sine test found in 'displacement'"):
        characterise(models["damper"], tmp_path / "out", measured=record, log=print)
    assert not (tmp_path / "out").exists()


def test_a_model_that_is_neither_is_refused_naming_the_file(tmp_path: Path) -> None:
    graph = GraphBuilder(reserved=["u", "y"])
    graph.output(graph.node("Identity", ["u"], "copy"), "y")
    path = tmp_path / "other.onnx"
    onnx.save(graph.model("other", "y = u", [("u", 1)], [("y", 1)]), str(path))
    result = CliRunner().invoke(app, ["characterise", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert "error:" in result.output and "other.onnx: neither a damper" in result.output


def test_a_bushing_rigs_sine_record_beside_the_truth_bushing(models: dict[str, Path], tmp_path: Path) -> None:
    """The rig's dynamic-stiffness series of the same law: found per level, within 0.5 % and 0.1 deg of the FMU."""
    rig = BushingRig(sine_frequencies=(2.0, 10.0), sine_amplitudes=(0.5, 1.0))
    time, channels, _ = run_bushing_rig(
        BushingParams(), ("viscoelastic", "friction"), rig, 1 / T, 12000, "sine", 1.0, 3
    )
    record = tmp_path / "rig.csv"
    save_measurement(Measurement(time, channels, {k: BUSHING_UNITS[k] for k in channels}), record)
    characterise(models["bushing"], tmp_path / "out", measured=record, log=print)
    rows = _rows(tmp_path / "out" / "dynamic_stiffness.csv")
    found = [(float(r["frequency [Hz]"]), float(r["amplitude [m]"])) for r in rows]
    assert [f for f, _ in found] == pytest.approx([2.0, 2.0, 10.0, 10.0], rel=1e-3)
    assert [a for _, a in found] == pytest.approx([1.25e-3, 2.5e-3, 1.25e-3, 2.5e-3], rel=1e-3)
    for row in rows:
        assert abs(float(row["stiffness_deviation [%]"])) < 0.5
        assert abs(float(row["loss_angle_deviation [deg]"])) < 0.1
    loop = _rows(tmp_path / "out" / "quasi_static_loop.csv")
    assert {"measured_axial_displacement [m]", "measured_axial_force [N]"} <= set(loop[0])


@pytest.mark.slow
def test_a_semi_active_damper_gets_a_family_of_curves_per_command(tmp_path: Path) -> None:
    """force = (c0 + c1·voltage)·velocity, its voltage input trained over 0-5 V: five levels by default."""
    graph = GraphBuilder(reserved=["velocity", "voltage", "force"])
    gain = graph.node(
        "Add",
        [
            graph.constant("c0", np.array([1000.0])),
            graph.node("Mul", ["voltage", graph.constant("c1", np.array([400.0]))], "slope"),
        ],
        "damping",
    )
    graph.output(graph.node("Mul", ["velocity", gain], "product"), "force")
    model = graph.model("mr", "(c0 + c1 u) v", [("velocity", 1), ("voltage", 1)], [("force", 1)])
    Component(
        "mr",
        [Port("velocity", "m/s"), Port("voltage", "V", min=0.0, max=5.0)],
        [Port("force", "N")],
        sample_period=T,
    ).attach_to(model)
    path = tmp_path / "mr.onnx"
    onnx.save(model, str(path))
    settings = CharacteriseSettings(damper=DamperTestSettings(peak_velocities=(1.0,), stroke=0.02, settle_cycles=1))
    characterise(path, tmp_path / "out", settings=settings, log=print)
    rows = _rows(tmp_path / "out" / "characteristic.csv")
    assert [float(r["voltage [V]"]) for r in rows] == [0.0, 1.25, 2.5, 3.75, 5.0]
    for row in rows:
        c = 1000.0 + 400.0 * float(row["voltage [V]"])
        v = float(row["peak_velocity [m/s]"])
        assert float(row["rebound_force [N]"]) == pytest.approx(c * v, rel=1e-4)
        assert float(row["jounce_force [N]"]) == pytest.approx(-c * v, rel=1e-4)
    assert len(_rows(tmp_path / "out" / "gas_friction.csv")) == 5
    html = (tmp_path / "out" / "index.html").read_text(encoding="utf-8")
    assert html.count("work_0") >= 10  # a force-displacement and a force-velocity diagram per level (5 x 2 images)
