"""Reference results inside the FMU (FMI-LS-REF) and `nnfmu check`.

Network FMUs built from an exported graph carry stimuli and onnxruntime's outputs and pass the check (FMI 2, FMI 3,
the pythonfmu backend, a merged graph); an FMU built from a graph with one weight changed, carrying the original's
reference folder, fails naming its output; an FMU of another producer with hand-written data in the layout (the
format document's attribute form, an SSV parameter set, numpy's expected values) passes, and fails when a reference
value is off; a tampered file fails its checksum; an FMU without data is an error.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import re
import zipfile
from pathlib import Path

import numpy as np
import onnx
import pytest
from exported_networks import FORCE, HELD_OUT_SEED_OFFSET, TORQUE, T, export_network, signals
from onnx import numpy_helper
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.export.merge import merge_step_graphs
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.check import CheckError, check_fmu, report_lines
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.reference_results import LS_FOLDER, TOLERANCE
from nnfmu.fmu.step_graph import GRAPH_MEMBER
from nnfmu.reference_stimulus import METADATA_KEY, REFERENCE_SAMPLES, ReferenceStimulus

runner = CliRunner()


@pytest.fixture(scope="module")
def network(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("reference")
    onnx_path = export_network(FORCE, folder / "force.onnx", 1)
    fmus = {f"fmi{v}": build_fmu(onnx_path, BuildOptions(out=folder / f"force{v}.fmu", fmi_version=v)) for v in (2, 3)}
    return {"onnx": onnx_path, **fmus}


def _replace(fmu: Path, files: dict[str, bytes], target: Path, drop: tuple[str, ...] = ()) -> Path:
    """A copy of `fmu` at `target` with `files` added or replaced and paths starting with `drop` left out."""
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as out:
        for name in source.namelist():
            if name not in files and not name.startswith(drop):
                out.writestr(name, source.read(name))
        for name, content in files.items():
            out.writestr(name, content)
    return target


@pytest.mark.slow
def test_export_stores_the_first_held_out_inputs_as_stimulus(network):
    model = onnx.load(network["onnx"])
    stimulus = ReferenceStimulus.from_onnx(model)
    held_out = signals(FORCE.channels, 700, 1 + HELD_OUT_SEED_OFFSET)
    assert stimulus is not None and stimulus.length == REFERENCE_SAMPLES
    for name in FORCE.channels:
        np.testing.assert_array_equal(stimulus.inputs[name], held_out[name][:REFERENCE_SAMPLES])
    assert "input data the export was verified on" in stimulus.source
    assert sum(p.key == METADATA_KEY for p in model.metadata_props) == 1


@pytest.mark.parametrize("fmi", [2, 3])
def test_network_fmu_passes_its_reference_check(network, fmi):
    report = check_fmu(network[f"fmi{fmi}"])
    assert report.passed
    [experiment] = report.experiments
    assert experiment.samples == REFERENCE_SAMPLES and experiment.step_size == T and experiment.tolerance == TOLERANCE
    [output] = experiment.outputs
    assert output.name == "axial_force" and output.max_error < 1e-12 * output.allowed / TOLERANCE
    result = runner.invoke(app, ["check", str(network[f"fmi{fmi}"])])
    assert result.exit_code == 0, result.output
    assert "axial_force: max error" in result.output and "result: pass" in result.output


def test_reference_data_is_the_standard_layout_with_checksums(network):
    with zipfile.ZipFile(network["fmi2"]) as archive:
        manifest = archive.read(f"{LS_FOLDER}/fmi-ls-manifest.xml").decode()
        experiments = archive.read(f"{LS_FOLDER}/reference.exp").decode()
        stimuli = archive.read(f"{LS_FOLDER}/stimuli.csv")
        header = next(csv.reader(io.StringIO(archive.read(f"{LS_FOLDER}/references.csv").decode())))
        assert "documentation/fmi-ls-ref.txt" in archive.namelist()
    assert 'fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref"' in manifest
    assert 'type="application/x-ma-hs-experiments"' in manifest and 'role="experiment/smoke-test"' in manifest
    assert f'checksum="{hashlib.sha3_256(stimuli).hexdigest()}"' in manifest
    assert '<TransientSimulation startTime="0.0" stopTime="0.499" stepSize="0.001"' in experiments
    assert header == ["time", "axial_force"]


def test_pythonfmu_backend_carries_the_same_reference_and_passes(network, tmp_path):
    fmu = build_fmu(network["onnx"], BuildOptions(out=tmp_path / "py.fmu", backend="pythonfmu"))
    names = [f"{LS_FOLDER}/references.csv", f"{LS_FOLDER}/stimuli.csv"]
    with zipfile.ZipFile(fmu) as ours, zipfile.ZipFile(network["fmi2"]) as native:
        assert [ours.read(n) for n in names] == [native.read(n) for n in names]
    assert check_fmu(fmu).passed


def test_fmu_with_one_weight_changed_fails_naming_the_output(network, tmp_path):
    model = onnx.load(network["onnx"])
    weights = max((i for i in model.graph.initializer if len(i.dims) == 2), key=lambda i: np.prod(i.dims))
    array = numpy_helper.to_array(weights).copy()
    array.flat[0] *= 1.01  # one weight of the first layer, 1 % off
    weights.CopyFrom(numpy_helper.from_array(array, weights.name))
    onnx.save(model, tmp_path / "altered.onnx")
    altered = build_fmu(tmp_path / "altered.onnx", BuildOptions(out=tmp_path / "altered.fmu"))
    assert check_fmu(altered).passed  # its own reference results follow its own graph
    with zipfile.ZipFile(network["fmi2"]) as original:
        kept = {n: original.read(n) for n in original.namelist() if n.startswith((LS_FOLDER, "documentation/"))}
    transplanted = _replace(altered, kept, tmp_path / "transplanted.fmu", drop=(LS_FOLDER, "documentation/"))
    report = check_fmu(transplanted)
    assert not report.passed
    [output] = report.experiments[0].outputs
    assert output.name == "axial_force" and output.max_error > 1e3 * output.allowed
    result = runner.invoke(app, ["check", str(transplanted)])
    assert result.exit_code == 1
    assert "axial_force" in result.output and "FAIL" in result.output


@pytest.mark.slow
def test_merged_graph_fmu_carries_the_parts_stimuli_and_passes(tmp_path):
    parts = [
        onnx.load(export_network(FORCE, tmp_path / "force.onnx", 3)),
        onnx.load(export_network(TORQUE, tmp_path / "t.onnx", 4)),
    ]
    merged = merge_step_graphs(parts, "bushing", "force and torque")
    stimulus = ReferenceStimulus.from_onnx(merged)
    assert stimulus is not None and set(stimulus.inputs) == set(FORCE.channels) | set(TORQUE.channels)
    onnx.save(merged, tmp_path / "bushing.onnx")
    fmu = build_fmu(tmp_path / "bushing.onnx", BuildOptions(out=tmp_path / "bushing.fmu", fmi_version=3))
    report = check_fmu(fmu)
    assert report.passed and [o.name for o in report.experiments[0].outputs] == ["axial_force", "axial_torque"]


def _other_producer_data(fmu: Path, perturb: float = 0.0) -> dict[str, bytes]:
    """Hand-written FMI-LS-REF data for the generic graph's FMU (y = tanh(x W), z = sum x; no sample period):
    the attribute form of the experiments format, in a sub-folder, with an SSV parameter set; references by numpy."""
    w = np.array([[0.5, -1.0], [2.0, 0.25], [-0.75, 1.5]])
    gain, step, n = 2.0, 0.01, 60
    t = np.arange(n) * step
    x = np.stack([np.sin(2 * np.pi * 3 * t), 0.5 * np.cos(2 * np.pi * 5 * t), t], axis=1)
    held = np.concatenate([x[:1], x[:-1]])  # evaluated at the end of each step with the inputs set before it
    y, z = gain * np.tanh(held @ w), gain * held.sum(axis=1)
    y[17, 1] += perturb
    stimuli = "\n".join(
        ['"time","x[0]","x[1]","x[2]"', *(",".join(repr(float(v)) for v in (t[k], *x[k])) for k in range(n))]
    )
    refs = "\n".join(
        ['"time","y[0]","y[1]","z"', *(",".join(repr(float(v)) for v in (t[k], *y[k], z[k])) for k in range(n))]
    )
    experiments = (
        f'<?xml version="1.0" encoding="UTF-8"?>\n<Experiments name="acceptance">\n'
        f'  <Experiment name="sweep" startTime="0" stopTime="{float(t[-1])!r}" stepSize="{step}" '
        'tolerance="1e-12">\n'
        '    <Parameters source="params.ssv"/>\n    <Stimuli source="in.csv"/>\n'
        '    <References source="ref.csv"/>\n  </Experiment>\n</Experiments>\n'
    )
    parameters = (
        '<?xml version="1.0" encoding="UTF-8"?>\n<ssv:ParameterSet version="1.0" name="acceptance" '
        'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"><ssv:Parameters>'
        f'<ssv:Parameter name="output_gain"><ssv:Real value="{gain}"/></ssv:Parameter>'
        '<ssv:Parameter name="filter_cutoff"><ssv:Real value="0"/></ssv:Parameter>'
        "</ssv:Parameters></ssv:ParameterSet>\n"
    )
    manifest = (
        '<?xml version="1.0" encoding="UTF-8"?>\n<fmiReferences '
        'xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest" '
        'fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref" '
        'fmi-ls:fmi-ls-version="1.0.0-alpha.1" fmi-ls:fmi-ls-description="Layered Standard providing '
        'information on related files included in an FMU.">\n'
        '  <Related type="application/x-ma-hs-experiments" source="tests/acceptance.exp" role="experiment"/>\n'
        "</fmiReferences>\n"
    )
    folder = f"{LS_FOLDER}/tests"
    return {
        f"{LS_FOLDER}/fmi-ls-manifest.xml": manifest.encode(),
        f"{folder}/acceptance.exp": experiments.encode(),
        f"{folder}/params.ssv": parameters.encode(),
        f"{folder}/in.csv": stimuli.encode(),
        f"{folder}/ref.csv": refs.encode(),
    }


def test_fmu_of_another_producer_with_data_in_the_layout_passes_and_fails_when_off(generic_onnx, tmp_path):
    plain = build_fmu(generic_onnx, BuildOptions(out=tmp_path / "other.fmu"))
    with pytest.raises(CheckError, match="no reference results"):
        check_fmu(plain)
    assert runner.invoke(app, ["check", str(plain)]).exit_code == 2
    good = check_fmu(_replace(plain, _other_producer_data(plain), tmp_path / "good.fmu"))
    assert good.passed and [o.name for o in good.experiments[0].outputs] == ["y[0]", "y[1]", "z"]
    assert max(o.max_error for o in good.experiments[0].outputs) < 1e-14
    bad = check_fmu(_replace(plain, _other_producer_data(plain, perturb=1e-6), tmp_path / "bad.fmu"))
    assert [o.name for o in bad.experiments[0].outputs if not o.passed] == ["y[1]"]


def test_tampered_reference_file_fails_its_checksum(network, tmp_path):
    with zipfile.ZipFile(network["fmi3"]) as archive:
        text = archive.read(f"{LS_FOLDER}/stimuli.csv").decode()
    tampered = _replace(network["fmi3"], {f"{LS_FOLDER}/stimuli.csv": (text + "\n").encode()}, tmp_path / "t.fmu")
    report = check_fmu(tampered)
    assert not report.passed and report.checksum_errors == [
        f"{LS_FOLDER}/stimuli.csv: SHA3-256 checksum does not match the manifest"
    ]


def test_check_names_the_carried_step_graph_and_fails_when_it_was_swapped(network, tmp_path):
    assert report_lines(check_fmu(network["fmi2"]))[0].startswith(f"step graph: {GRAPH_MEMBER} (")
    other = export_network(TORQUE, tmp_path / "torque.onnx", 1).read_bytes()
    swapped = _replace(network["fmi2"], {GRAPH_MEMBER: other}, tmp_path / "swapped.fmu")
    report = check_fmu(swapped)
    assert not report.passed
    (problem,) = report.checksum_errors
    assert f"swapped.fmu: {GRAPH_MEMBER} has sha256" in problem and "altered or replaced after the build" in problem


@pytest.mark.parametrize(
    ("member", "data", "message"),
    [
        ("resources/zeros.bin", bytes(4 * 1024 * 1024), r"member 'resources/zeros\.bin' inflates \d+-fold"),
        ("../../escaped.txt", b"x", r"member '\.\./\.\./escaped\.txt' climbs out"),
    ],
)
def test_an_fmu_that_is_a_zip_bomb_or_climbs_out_is_refused_before_reading(network, tmp_path, member, data, message):
    hostile = _replace(network["fmi3"], {member: data}, tmp_path / "hostile.fmu")
    with pytest.raises(CheckError, match=message):
        check_fmu(hostile)


def test_graph_without_stimulus_gets_no_reference_results(delay_fmus):
    assert not any(n.startswith(LS_FOLDER) for n in zipfile.ZipFile(delay_fmus[2]).namelist())


def test_malformed_stimulus_fails_the_build_naming_the_key(network, tmp_path):
    from nnfmu.fmu.errors import FmuBuildError

    model = onnx.load(network["onnx"])
    for prop in model.metadata_props:
        if prop.key == METADATA_KEY:
            data = json.loads(prop.value)
            data["inputs"]["axial_velocity"][0] = float("nan")
            prop.value = json.dumps(data)
    onnx.save(model, tmp_path / "bad.onnx")
    with pytest.raises(FmuBuildError, match="nnfmu.reference_stimulus.*sample 0"):
        build_fmu(tmp_path / "bad.onnx", BuildOptions(out=tmp_path / "bad.fmu"))
    assert not (tmp_path / "bad.fmu").exists()


def test_an_fmu_without_its_model_description_is_one_check_error(network, tmp_path):
    """An FMU with reference results but no modelDescription.xml was a traceback from fmpy."""
    broken = _replace(network["fmi2"], {}, tmp_path / "nomd.fmu", drop=("modelDescription.xml",))
    with pytest.raises(CheckError, match=r"nomd\.fmu.*modelDescription\.xml"):
        check_fmu(broken)
    result = CliRunner().invoke(app, ["check", str(broken)])
    assert result.exit_code == 2 and result.output.startswith("error: "), result.output


@pytest.mark.parametrize(
    ("pattern", "value", "message"),
    [
        ("stopTime", "1e9", r"stop time 1e\+09 s .*steps of .* s .*more than the 1000000"),
        ("stepSize", "1e-12", r"stop time .* in steps of 1e-12 s .*more than the 1000000"),
        ("stopTime", "nan", r"stop time nan s is not a finite number"),
        ("stepSize", "-1e-3", r"step size -0\.001 s must be positive"),
    ],
)
def test_a_reference_experiment_past_the_step_limit_is_refused_before_simulating(
    network, tmp_path, pattern, value, message
):
    """A hostile experiment (a stop time of 1e9 s, a step of 1e-12 s, NaN) would keep `nnfmu check` busy for ever:
    its steps are counted and refused, naming the experiment, before the FMU is run."""
    name = f"{LS_FOLDER}/reference.exp"
    with zipfile.ZipFile(network["fmi2"]) as archive:
        text = archive.read(name).decode()
    assert f'{pattern}="' in text
    hostile = _replace(
        network["fmi2"],
        {name: re.sub(rf'{pattern}="[^"]*"', f'{pattern}="{value}"', text).encode()},
        tmp_path / "h.fmu",
    )
    with pytest.raises(CheckError, match=rf"h\.fmu: experiment 'reference': {message}"):
        check_fmu(hostile)


def test_a_default_experiment_step_past_the_limit_is_refused(network, tmp_path):
    """Without a step in the experiment, the model description's default experiment gives it: bounded the same way."""
    name = f"{LS_FOLDER}/reference.exp"
    with zipfile.ZipFile(network["fmi2"]) as archive:
        text = archive.read(name).decode()
        description = archive.read("modelDescription.xml").decode()
    files = {
        name: re.sub(r' stepSize="[^"]*"', "", text).encode(),
        "modelDescription.xml": re.sub(
            r'(<DefaultExperiment[^>]*) stepSize="[^"]*"', r'\1 stepSize="1e-12"', description
        ).encode(),
    }
    hostile = _replace(network["fmi2"], files, tmp_path / "d.fmu")
    with pytest.raises(CheckError, match=r"steps of 1e-12 s.*more than the 1000000"):
        check_fmu(hostile)


def test_a_model_description_failing_its_schema_is_one_line_naming_the_attribute(network, tmp_path):
    """fmpy's schema problems were printed below a first line naming nothing ('Failed to validate
    modelDescription.xml:'): the problems now stand in the one error line (a default stop time of 'nan' here)."""
    with zipfile.ZipFile(network["fmi2"]) as archive:
        description = archive.read("modelDescription.xml").decode()
    hostile = _replace(
        network["fmi2"],
        {"modelDescription.xml": description.replace("<DefaultExperiment", '<DefaultExperiment stopTime="nan"')},
        tmp_path / "nan.fmu",
    )
    with pytest.raises(CheckError) as caught:
        check_fmu(hostile)
    message = str(caught.value)
    assert "\n" not in message, message
    for words in ("nan.fmu", "modelDescription.xml", "DefaultExperiment", "stopTime", "'nan'"):
        assert words in message, message


@pytest.mark.parametrize("kind", ["FIFO", "device"])
def test_an_fmu_that_is_a_fifo_or_a_device_is_refused_before_it_is_opened(tmp_path, kind):
    """`nnfmu check` on a FIFO waited for ever for a writer, and on a link to /dev/zero read without end (killed for
    its memory): either is refused by name. (Before the fix a writer thread feeds the FIFO garbage after a moment,
    and a link to /dev/null reads as an empty file: both failed as 'not a readable FMU' instead.)"""
    import os
    import threading

    path = tmp_path / "model.fmu"
    stop = threading.Event()
    if kind == "FIFO":
        os.mkfifo(path)

        def feed() -> None:
            while not stop.wait(0.05):
                try:
                    handle = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
                except OSError:  # no reader yet (ENXIO)
                    continue
                os.write(handle, b"not a zip archive")
                os.close(handle)
                return

        threading.Thread(target=feed, daemon=True).start()
    else:
        path.symlink_to("/dev/null")
    try:
        with pytest.raises(
            CheckError, match=rf"model\.fmu: is a {kind if kind == 'FIFO' else 'device'}, not a regular"
        ):
            check_fmu(path)
    finally:
        stop.set()
