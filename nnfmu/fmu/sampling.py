"""The sample period an nnfmu FMU carries as a fact: an annotation of its model description, written by the factory
and read back by masters that must know it (the step-size hint of the default experiment is only a suggestion).

FMI 2: `<VendorAnnotations><Tool name="org.nnfmu"><Sampling period="T" unit="s"/></Tool></VendorAnnotations>`;
FMI 3: `<Annotations><Annotation type="org.nnfmu"><Sampling period="T" unit="s"/></Annotation></Annotations>`.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

from nnfmu.fmu.errors import FmuBuildError

ANNOTATION_TOOL = "org.nnfmu"
MODEL_DESCRIPTION = "modelDescription.xml"


class SamplingAnnotationError(FmuBuildError):
    """The sampling annotation of a model description is there but unreadable; names the file and the value."""


def annotate_sample_period(root: ET.Element, period: float, fmi_version: int) -> None:
    """Add the sampling annotation to a model description's root element (the pythonfmu backend's writer; the
    native backend's templates write the same element)."""
    ET.SubElement(tool_annotation(root, fmi_version, ANNOTATION_TOOL), "Sampling", period=repr(float(period)), unit="s")


def tool_annotation(root: ET.Element, fmi_version: int, tool: str) -> ET.Element:
    """A new tool element named `tool` in a model description's annotations (made where missing): FMI 2
    `VendorAnnotations/Tool[@name]`, FMI 3 `Annotations/Annotation[@type]`. Each holds one element, as the FMI 2
    schema allows."""
    outer, inner, key = (
        ("VendorAnnotations", "Tool", "name") if fmi_version == 2 else ("Annotations", "Annotation", "type")
    )
    annotations = root.find(outer)
    if annotations is None:
        annotations = ET.SubElement(root, outer)
    return ET.SubElement(annotations, inner, {key: tool})


def read_sample_period(model_description: Path) -> float | None:
    """The sample period [s] annotated in the model description file, or None (no annotation: a stateless graph or
    another tool's FMU). A malformed annotation raises SamplingAnnotationError naming the file."""
    return _annotated_period(ET.parse(model_description).getroot(), str(model_description))


def fmu_sample_period(fmu: Path) -> float | None:
    """The sample period [s] annotated in the model description inside the FMU archive `fmu`, or None; a malformed
    annotation raises SamplingAnnotationError naming the FMU."""
    with zipfile.ZipFile(fmu) as archive:
        root = ET.fromstring(archive.read(MODEL_DESCRIPTION))
    return _annotated_period(root, f"{fmu}: {MODEL_DESCRIPTION}")


def _annotated_period(root: ET.Element, where: str) -> float | None:
    paths = (
        f"./VendorAnnotations/Tool[@name='{ANNOTATION_TOOL}']/Sampling",
        f"./Annotations/Annotation[@type='{ANNOTATION_TOOL}']/Sampling",
    )
    node = next((found for path in paths if (found := root.find(path)) is not None), None)
    if node is None:
        return None
    text = node.get("period", "")
    try:
        period = float(text)
    except ValueError:
        period = math.nan
    if not (math.isfinite(period) and period > 0) or node.get("unit", "s") != "s":
        raise SamplingAnnotationError(
            f"{where}: sampling annotation period={text!r} unit={node.get('unit')!r} is not a positive time in s"
        )
    return period
