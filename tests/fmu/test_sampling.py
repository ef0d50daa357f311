"""The sample period travels inside the FMU as a fact (a model-description annotation), for FMI 2 and 3 alike, and
a stateless graph carries none."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

from nnfmu.cosim import DEFAULT_STEP
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.sampling import SamplingAnnotationError, fmu_sample_period, read_sample_period
from nnfmu.workflows.vehicle_loop import VehicleLoopSettings


def _description(fmu: Path, folder: Path) -> Path:
    with zipfile.ZipFile(fmu) as archive:
        archive.extract("modelDescription.xml", folder)
    return folder / "modelDescription.xml"


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["native", "pythonfmu"])
@pytest.mark.parametrize("fmi_version", [2, 3])
def test_the_fmu_carries_its_sample_period(tmp_path: Path, fmi_version: int, backend: str) -> None:
    import onnx

    for period in (1e-3, None):
        onnx_path = tmp_path / f"damper_{period}.onnx"
        onnx.save(linear_damper_graph(1500.0, sample_period=period), onnx_path)
        fmu = build_fmu(
            onnx_path,
            BuildOptions(out=tmp_path / f"damper_{period}_{fmi_version}.fmu", fmi_version=fmi_version, backend=backend),
        )
        assert read_sample_period(_description(fmu, tmp_path / f"x_{period}_{fmi_version}")) == period
        assert fmu_sample_period(fmu) == period


def test_a_malformed_annotation_is_refused_naming_the_file(tmp_path: Path) -> None:
    path = tmp_path / "modelDescription.xml"
    for period, unit in (("0", "s"), ("fast", "s"), ("1e-3", "ms")):
        path.write_text(
            f'<fmiModelDescription><VendorAnnotations><Tool name="org.nnfmu"><Sampling period="{period}" '
            f'unit="{unit}"/></Tool></VendorAnnotations></fmiModelDescription>'
        )
        with pytest.raises(SamplingAnnotationError, match=f"Description.xml: sampling annotation period='{period}"):
            read_sample_period(path)


def test_a_malformed_annotation_inside_an_fmu_is_refused_naming_the_fmu(tmp_path: Path) -> None:
    fmu = tmp_path / "odd.fmu"
    with zipfile.ZipFile(fmu, "w") as archive:
        archive.writestr(
            "modelDescription.xml",
            '<fmiModelDescription><Annotations><Annotation type="org.nnfmu"><Sampling period="-1" unit="s"/>'
            "</Annotation></Annotations></fmiModelDescription>",
        )
    with pytest.raises(
        SamplingAnnotationError, match=r"odd\.fmu: modelDescription\.xml: sampling annotation period='-1'"
    ):
        fmu_sample_period(fmu)


def test_the_vehicle_loop_steps_at_the_vehicle_fmus_sample_period_unless_told(tmp_path: Path) -> None:
    """The vehicle FMU's period when no step is given (the finest its feedthrough allows), the master's default for
    an FMU without one, and a given step as given."""
    import onnx

    fmus = {}
    for period in (2e-3, None):
        onnx_path = tmp_path / f"vehicle_{period}.onnx"
        onnx.save(linear_damper_graph(1500.0, sample_period=period), onnx_path)
        fmus[period] = build_fmu(onnx_path, BuildOptions(out=tmp_path / f"vehicle_{period}.fmu", platforms=("host",)))
    assert VehicleLoopSettings().step_for(fmus[2e-3]) == 2e-3
    assert VehicleLoopSettings().step_for(fmus[None]) == DEFAULT_STEP
    assert VehicleLoopSettings(step=5e-4).step_for(fmus[2e-3]) == 5e-4
