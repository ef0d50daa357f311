"""The step graph an nnfmu FMU carries: its ONNX graph with the component description in its metadata, stored in
the archive at `extra/org.nnfmu/model.onnx` and bound to the FMU by digests in its model description.

Why: the tools that diagnose, retrain or fix a component (`nnfmu loop vehicle`, `nnfmu check`, the road test) need
the graph the FMU was built from; a file beside the FMU gets lost, or is another network. FMI 3 reserves `extra/`
for data that travels with an FMU, in a reverse-domain folder of whoever defines it; FMI-LS-REF uses the same folder
in FMI 2 FMUs. The FMI 3 standard also lets other tools change `extra/` without touching the FMU's validity, so the
model description (the FMU's core) records the embedded file's sha256 and the digest of its graph (nodes and
weights, without metadata), in an annotation of tool `org.nnfmu.step-graph` (FMI 2 `VendorAnnotations/Tool`, FMI 3
`Annotations/Annotation`): `<StepGraph file="extra/org.nnfmu/model.onnx" sha256="..." graphSha256="..."/>`. A
reader checks the file against the first, and any other ONNX offered for the FMU (beside it, or given) against the
second.
"""

from __future__ import annotations

import hashlib
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass
from pathlib import Path

import onnx

from nnfmu.component import Component
from nnfmu.errors import NnfmuError
from nnfmu.fmu.sampling import tool_annotation
from nnfmu.safe_zip import check_members

GRAPH_MEMBER = "extra/org.nnfmu/model.onnx"
ANNOTATION_TOOL = "org.nnfmu.step-graph"  # its own tool element: an FMI 2 `Tool` holds one element
MAX_GRAPH_BYTES = 64 * 1024 * 1024  # a small network's graph is a few kB, a vehicle's tens of kB


class StepGraphError(NnfmuError):
    """An FMU's step graph record is malformed, its embedded graph is missing or altered, or another ONNX offered
    for it is a different network; names the file and the digests."""


@dataclass(frozen=True)
class StepGraphRecord:
    """Where the FMU holds its graph, the sha256 of that file and of its graph proto (nodes and weights)."""

    member: str
    sha256: str
    graph_sha256: str


@dataclass(frozen=True)
class EmbeddedGraph:
    """The bytes written at `record.member` and their record."""

    data: bytes
    record: StepGraphRecord


def graph_digest(model: onnx.ModelProto) -> str:
    """sha256 of the graph proto alone: the same network gives the same digest whatever its metadata (name,
    component description) says."""
    return hashlib.sha256(model.graph.SerializeToString()).hexdigest()


def embedded_graph(model: onnx.ModelProto, component: Component) -> EmbeddedGraph:
    """The graph with `component` attached as the FMU will carry it (the caller's graph is not modified)."""
    copy = onnx.ModelProto()
    copy.CopyFrom(model)
    component.attach_to(copy)
    data = copy.SerializeToString()
    return EmbeddedGraph(data, StepGraphRecord(GRAPH_MEMBER, hashlib.sha256(data).hexdigest(), graph_digest(copy)))


def write_embedded_graph(tree: Path, graph: EmbeddedGraph) -> None:
    """Write the graph into the FMU folder `tree` at its member path."""
    target = tree / graph.record.member
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_bytes(graph.data)


def annotate_step_graph(root: ET.Element, record: StepGraphRecord, fmi_version: int) -> None:
    """Add the `<StepGraph>` record to a model description's annotations (the pythonfmu backend's writer;
    the native backend's templates write the same element)."""
    ET.SubElement(
        tool_annotation(root, fmi_version, ANNOTATION_TOOL),
        "StepGraph",
        file=record.member,
        sha256=record.sha256,
        graphSha256=record.graph_sha256,
    )


def read_record(root: ET.Element, where: str) -> StepGraphRecord | None:
    """The `<StepGraph>` record of a parsed model description, or None (an FMU of another tool or an older nnfmu);
    StepGraphError naming `where` for a malformed one."""
    paths = (
        f"./VendorAnnotations/Tool[@name='{ANNOTATION_TOOL}']/StepGraph",
        f"./Annotations/Annotation[@type='{ANNOTATION_TOOL}']/StepGraph",
    )
    node = next((found for path in paths if (found := root.find(path)) is not None), None)
    if node is None:
        return None
    member, sha, graph = node.get("file", ""), node.get("sha256", ""), node.get("graphSha256", "")
    if member != GRAPH_MEMBER or not _is_sha256(sha) or not _is_sha256(graph):
        raise StepGraphError(
            f"{where}: step graph record file={member!r} sha256={sha!r} graphSha256={graph!r} is malformed "
            f"(expected file={GRAPH_MEMBER!r} and two 64-digit hex sha256 digests)"
        )
    return StepGraphRecord(member, sha, graph)


def _is_sha256(text: str) -> bool:
    return len(text) == 64 and all(c in "0123456789abcdef" for c in text)


def read_fmu_graph(fmu: Path) -> tuple[bytes, StepGraphRecord] | None:
    """The embedded graph's bytes and record of the FMU at `fmu`, checked against its sha256; None when the FMU
    records no step graph. StepGraphError naming the FMU when the record is there but the file is missing, too
    large or altered; the archive is read through `safe_zip`'s member checks."""
    fmu = Path(fmu)
    try:
        with zipfile.ZipFile(fmu) as archive:
            names = {m.filename for m in check_members(archive, fmu)}
            if "modelDescription.xml" not in names:
                raise StepGraphError(f"{fmu}: no modelDescription.xml in the FMU")
            root = ET.fromstring(archive.read("modelDescription.xml"))
            record = read_record(root, f"{fmu} (modelDescription.xml)")
            if record is None:
                return None
            if record.member not in names:
                raise StepGraphError(f"{fmu}: the step graph {record.member} its model description records is missing")
            size = archive.getinfo(record.member).file_size
            if size > MAX_GRAPH_BYTES:
                raise StepGraphError(f"{fmu}: {record.member} holds {size} bytes, more than {MAX_GRAPH_BYTES}")
            data = archive.read(record.member)
    except (zipfile.BadZipFile, ET.ParseError, OSError) as err:
        raise StepGraphError(f"{fmu}: cannot read the FMU's step graph record: {err}") from err
    found = hashlib.sha256(data).hexdigest()
    if found != record.sha256:
        raise StepGraphError(
            f"{fmu}: {record.member} has sha256 {found}, not the {record.sha256} its model description records: "
            "the graph was altered or replaced after the build"
        )
    return data, record


def extract_fmu_graph(fmu: Path, target: Path) -> StepGraphRecord | None:
    """Write the FMU's checked embedded graph to `target` (an ONNX file) and return its record; None (nothing
    written) when the FMU records no step graph."""
    found = read_fmu_graph(fmu)
    if found is None:
        return None
    data, record = found
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_bytes(data)
    return record


def check_same_graph(onnx_path: Path, record: StepGraphRecord, fmu: Path) -> None:
    """StepGraphError unless the ONNX file at `onnx_path` holds the network the FMU was built from (same graph
    digest; its metadata may differ)."""
    try:
        model = onnx.load(str(onnx_path))
    except Exception as err:  # onnx raises DecodeError, OSError or its own errors
        raise StepGraphError(f"{onnx_path}: cannot read the ONNX model: {err}") from err
    found = graph_digest(model)
    if found != record.graph_sha256:
        raise StepGraphError(
            f"{onnx_path} is not the network {fmu} was built from (graph sha256 {found[:12]}…, the FMU's "
            f"{record.graph_sha256[:12]}…)"
        )


def load_fmu_graph(fmu: Path) -> onnx.ModelProto:
    """The checked step graph the FMU at `fmu` carries; StepGraphError naming the FMU when it records none."""
    found = read_fmu_graph(fmu)
    if found is None:
        raise StepGraphError(f"{fmu}: the FMU records no step graph (another tool's or an older nnfmu's); rebuild it")
    return onnx.load_from_string(found[0])
