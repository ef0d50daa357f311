"""Read and write SSP 1.0 system structure files (`SystemStructure.ssd`): FMU elements, connectors, connections.

SSP is the FMI ecosystem's standard for a system of FMUs, so a system written here also runs in libcosim. Only the
part a fixed-step co-simulation needs is used: `ssd:System` with `ssd:Elements/ssd:Component` (an FMU, `source`
relative to the `.ssd` or inside an `.ssp` zip), each component's `ssd:Connectors` (name and kind, Real type) and
its parameter values inline (`ssd:ParameterBindings/ssd:ParameterBinding/ssd:ParameterValues/ssv:ParameterSet`),
the `ssd:Connections`, and `ssd:DefaultExperiment` (start and stop time). XML escaping is left to ElementTree, so any
name round-trips.
"""

from __future__ import annotations

import math
import os
import shutil
import urllib.parse
import urllib.request
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from nnfmu.atomic import atomic_path, scratch_dir
from nnfmu.cosim.units import PortUnit, UnitError, input_conversion, port_unit
from nnfmu.errors import NnfmuError
from nnfmu.input_files import not_regular
from nnfmu.safe_zip import ArchiveError, check_zip, confined_source, extract_zip

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
SSD_NAME = "SystemStructure.ssd"
FMU_TYPE = "application/x-fmu-sharedlibrary"
KINDS = ("input", "output", "parameter", "calculatedParameter")

ET.register_namespace("ssd", SSD)
ET.register_namespace("ssc", SSC)
ET.register_namespace("ssv", SSV)


class SspError(NnfmuError, ValueError):
    """A system file that cannot be read or does not fit its FMUs; the message names file, element and connector."""


@dataclass(frozen=True)
class Connector:
    """One port of an element: its FMU variable name and kind ('input', 'output', 'parameter')."""

    name: str
    kind: str


@dataclass(frozen=True)
class Element:
    """An FMU in the system: element name, FMU path as written in the file (`source`), connectors, parameter values."""

    name: str
    source: str
    connectors: tuple[Connector, ...] = ()
    parameters: Mapping[str, float] = field(default_factory=dict)

    def connector(self, name: str) -> Connector | None:
        return next((c for c in self.connectors if c.name == name), None)


@dataclass(frozen=True)
class Connection:
    """start_element.start_connector (an output) drives end_element.end_connector (an input)."""

    start_element: str
    start_connector: str
    end_element: str
    end_connector: str

    def __str__(self) -> str:
        return f"{self.start_element}.{self.start_connector} -> {self.end_element}.{self.end_connector}"


@dataclass
class SystemStructure:
    """A system of FMUs; `base` is the folder the elements' `source` paths are relative to, `path` the `.ssd` file
    it was read from (None for a system built in memory)."""

    name: str
    elements: list[Element]
    connections: list[Connection]
    base: Path = Path(".")
    start_time: float = 0.0
    stop_time: float | None = None
    path: Path | None = None

    def element(self, name: str) -> Element:
        for element in self.elements:
            if element.name == name:
                return element
        raise SspError(f"system {self.name!r}: no element {name!r} (has: {', '.join(e.name for e in self.elements)})")

    def fmu_path(self, element: str | Element) -> Path:
        element = self.element(element) if isinstance(element, str) else element
        return self.base / local_path(element.source, f"system {self.name!r}: element {element.name!r}")


def _q(ns: str, tag: str) -> str:
    return f"{{{ns}}}{tag}"


def _number(value: float) -> str:
    return repr(float(value))


def write_ssd(system: SystemStructure, path: str | os.PathLike[str]) -> Path:
    """Write `system` as an SSP 1.0 `.ssd` file (via a temporary file and a rename); return the path."""
    root = ET.Element(_q(SSD, "SystemStructureDescription"), {"version": "1.0", "name": system.name})
    sys_el = ET.SubElement(root, _q(SSD, "System"), {"name": system.name})
    elements = ET.SubElement(sys_el, _q(SSD, "Elements"))
    for element in system.elements:
        comp = ET.SubElement(
            elements, _q(SSD, "Component"), {"name": element.name, "source": element.source, "type": FMU_TYPE}
        )
        connectors = ET.SubElement(comp, _q(SSD, "Connectors"))
        for connector in element.connectors:
            if connector.kind not in KINDS:
                raise SspError(
                    f"element {element.name!r}, connector {connector.name!r}: kind {connector.kind!r} "
                    f"is not one of {', '.join(KINDS)}"
                )
            conn = ET.SubElement(connectors, _q(SSD, "Connector"), {"name": connector.name, "kind": connector.kind})
            ET.SubElement(conn, _q(SSC, "Real"))
        if element.parameters:
            bindings = ET.SubElement(comp, _q(SSD, "ParameterBindings"))
            values = ET.SubElement(ET.SubElement(bindings, _q(SSD, "ParameterBinding")), _q(SSD, "ParameterValues"))
            pset = ET.SubElement(values, _q(SSV, "ParameterSet"), {"version": "1.0", "name": f"{element.name}"})
            params = ET.SubElement(pset, _q(SSV, "Parameters"))
            for name, value in element.parameters.items():
                param = ET.SubElement(params, _q(SSV, "Parameter"), {"name": name})
                ET.SubElement(param, _q(SSV, "Real"), {"value": _number(value)})
    connections = ET.SubElement(sys_el, _q(SSD, "Connections"))
    for c in system.connections:
        ET.SubElement(
            connections,
            _q(SSD, "Connection"),
            {
                "startElement": c.start_element,
                "startConnector": c.start_connector,
                "endElement": c.end_element,
                "endConnector": c.end_connector,
            },
        )
    experiment = {"startTime": _number(system.start_time)}
    if system.stop_time is not None:
        experiment["stopTime"] = _number(system.stop_time)
    ET.SubElement(root, _q(SSD, "DefaultExperiment"), experiment)
    ET.indent(root)
    path = Path(path)
    with atomic_path(path) as tmp:
        ET.ElementTree(root).write(tmp, encoding="UTF-8", xml_declaration=True)
    return path


def _required(node: ET.Element, attribute: str, where: str) -> str:
    value = node.get(attribute)
    if value is None:
        raise SspError(f"{where}: missing attribute {attribute!r}")
    return value


def _float(text: str, where: str) -> float:
    """A finite number: FMUs refuse NaN and infinite values, and a time must be one."""
    try:
        value = float(text)
    except ValueError:
        raise SspError(f"{where}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise SspError(f"{where}: {text!r} is not a finite number")
    return value


def local_path(source: str, where: str) -> str:
    """An element's `source` (a URI reference, SSP 1.0 section 5.1) as a file path: a `file:` URI is read as its
    path, a relative reference or path is kept; other schemes (http:, ...) are refused, nnfmu reads no network."""
    parsed = urllib.parse.urlsplit(source)
    if len(parsed.scheme) <= 1:  # no scheme, or a Windows drive letter
        return source
    if parsed.scheme.lower() != "file":
        raise SspError(
            f"{where}: source {source!r} is a {parsed.scheme}: URI; give a local file (a relative path or a file: URI)"
        )
    if parsed.netloc not in ("", "localhost"):
        raise SspError(f"{where}: source {source!r} names the host {parsed.netloc!r}; give a local file")
    return urllib.request.url2pathname(parsed.path)


def _read_element(node: ET.Element, path: Path) -> Element:
    name = _required(node, "name", f"{path}: ssd:Component")
    where = f"{path}: element {name!r}"
    source = _required(node, "source", where)
    local_path(source, where)  # a source nnfmu cannot open is refused here, naming the element
    kind = node.get("type", FMU_TYPE)
    if kind != FMU_TYPE:
        raise SspError(f"{where}: type {kind!r}; only FMUs ({FMU_TYPE}) can be co-simulated")
    connectors = []
    for conn in node.findall(f"{_q(SSD, 'Connectors')}/{_q(SSD, 'Connector')}"):
        cname = _required(conn, "name", f"{where}: ssd:Connector")
        ckind = _required(conn, "kind", f"{where}, connector {cname!r}")
        if ckind not in KINDS:
            raise SspError(f"{where}, connector {cname!r}: kind {ckind!r} is not one of {', '.join(KINDS)}")
        connectors.append(Connector(cname, ckind))
    parameters: dict[str, float] = {}
    for binding in node.findall(f"{_q(SSD, 'ParameterBindings')}/{_q(SSD, 'ParameterBinding')}"):
        if binding.get("source"):
            raise SspError(
                f"{where}: parameter file {binding.get('source')!r} is not supported; "
                "give the values inline (ssd:ParameterValues)"
            )
        for param in binding.iter(_q(SSV, "Parameter")):
            pname = _required(param, "name", f"{where}: ssv:Parameter")
            real = param.find(_q(SSV, "Real"))
            if real is None:
                raise SspError(f"{where}, parameter {pname!r}: only ssv:Real values are supported")
            parameters[pname] = _float(
                _required(real, "value", f"{where}, parameter {pname!r}"), f"{where}, parameter {pname!r}"
            )
    return Element(name, source, tuple(connectors), parameters)


def read_ssd(path: str | os.PathLike[str], base: Path | None = None) -> SystemStructure:
    """Read an `.ssd` file; FMU sources are relative to `base` (default: the file's folder)."""
    path = Path(path)
    why = not_regular(path)
    if why:
        raise SspError(f"{path}: {why}")
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as error:
        raise SspError(f"{path}: cannot read the system structure: {error}") from None
    if root.tag != _q(SSD, "SystemStructureDescription"):
        raise SspError(f"{path}: root element {root.tag!r} is not ssd:SystemStructureDescription (SSP 1.0)")
    sys_el = root.find(_q(SSD, "System"))
    if sys_el is None:
        raise SspError(f"{path}: no ssd:System")
    elements = [_read_element(node, path) for node in sys_el.findall(f"{_q(SSD, 'Elements')}/{_q(SSD, 'Component')}")]
    others = [child.tag for child in sys_el.findall(f"{_q(SSD, 'Elements')}/*") if child.tag != _q(SSD, "Component")]
    if others:
        raise SspError(f"{path}: only ssd:Component elements are supported (found {', '.join(others)})")
    connections = []
    for node in sys_el.findall(f"{_q(SSD, 'Connections')}/{_q(SSD, 'Connection')}"):
        where = f"{path}: ssd:Connection"
        if node.get("startElement") is None or node.get("endElement") is None:
            raise SspError(
                f"{where}: connections to the system's own connectors are not supported (startConnector "
                f"{node.get('startConnector')!r}, endConnector {node.get('endConnector')!r})"
            )
        connections.append(
            Connection(
                _required(node, "startElement", where),
                _required(node, "startConnector", where),
                _required(node, "endElement", where),
                _required(node, "endConnector", where),
            )
        )
    experiment = root.find(_q(SSD, "DefaultExperiment"))
    start, stop = 0.0, None
    if experiment is not None:
        start = _float(experiment.get("startTime", "0"), f"{path}: DefaultExperiment startTime")
        if experiment.get("stopTime") is not None:
            stop = _float(experiment.get("stopTime", ""), f"{path}: DefaultExperiment stopTime")
    system = SystemStructure(
        name=root.get("name") or sys_el.get("name") or path.stem,
        elements=elements,
        connections=connections,
        base=path.parent if base is None else base,
        start_time=start,
        stop_time=stop,
        path=path,
    )
    _check_structure(system, path)
    return system


def _check_structure(system: SystemStructure, path: Path) -> None:
    """Elements are unique, connections join declared connectors of existing elements, output to input."""
    names = [e.name for e in system.elements]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise SspError(f"{path}: element name(s) used twice: {', '.join(map(repr, duplicates))}")
    driven: dict[tuple[str, str], Connection] = {}
    for c in system.connections:
        for element_name, connector_name, want in (
            (c.start_element, c.start_connector, "output"),
            (c.end_element, c.end_connector, "input"),
        ):
            element = system.element(element_name)
            connector = element.connector(connector_name)
            if connector is None:
                raise SspError(
                    f"{path}: connection {c}: element {element_name!r} declares no connector "
                    f"{connector_name!r} (has: {', '.join(x.name for x in element.connectors)})"
                )
            if connector.kind != want:
                raise SspError(
                    f"{path}: connection {c}: connector {element_name}.{connector_name} is an "
                    f"{connector.kind}, expected an {want}"
                )
        key = (c.end_element, c.end_connector)
        if key in driven:
            raise SspError(f"{path}: input {c.end_element}.{c.end_connector} is driven twice ({driven[key]}; {c})")
        driven[key] = c


def check_against_fmus(system: SystemStructure) -> None:
    """Every element's FMU exists and has each declared connector as a Real variable of the same causality, and
    every connection joins units the master can convert (`nnfmu.cosim.units`: the same unit, or units of one
    quantity by the FMU's UnitDefinitions or nnfmu's unit table, or an end without a unit)."""
    from fmpy import read_model_description

    units: dict[tuple[str, str], PortUnit] = {}
    for element in system.elements:
        fmu = system.fmu_path(element)
        if not fmu.is_file():
            raise SspError(f"system {system.name!r}: element {element.name!r}: FMU {fmu} not found")
        try:
            check_zip(fmu)  # a zip bomb or a member climbing out, before fmpy reads or extracts anything
            description = read_model_description(str(fmu))
        except Exception as error:  # fmpy raises plain exceptions for broken archives and XML
            raise SspError(f"system {system.name!r}: element {element.name!r}: cannot read {fmu}: {error}") from None
        variables = {v.name: v for v in description.modelVariables}
        declared = [(c.name, c.kind) for c in element.connectors] + [(p, "parameter") for p in element.parameters]
        for name, kind in declared:
            variable = variables.get(name)
            if variable is None:
                raise SspError(
                    f"system {system.name!r}: element {element.name!r}: connector {name!r} is not a "
                    f"variable of {fmu.name} (its variables: {', '.join(variables)})"
                )
            if variable.type not in ("Real", "Float64"):
                raise SspError(
                    f"system {system.name!r}: element {element.name!r}: connector {name!r} is of type "
                    f"{variable.type}; only Real connectors are supported"
                )
            if variable.causality != kind:
                raise SspError(
                    f"system {system.name!r}: element {element.name!r}: connector {name!r} is declared "
                    f"{kind} but is {variable.causality} in {fmu.name}"
                )
            units[(element.name, name)] = port_unit(variable, description.unitDefinitions or ())
            if kind == "parameter":
                _check_range(system, element, name, variable, fmu)
    _check_units(system, units)


def _check_range(system: SystemStructure, element: Element, name: str, variable: Any, fmu: Path) -> None:
    """SspError naming the element, parameter and bound when a parameter value lies outside the min/max its FMU
    declares (the FMU would refuse it only at run time)."""
    value = element.parameters[name]
    for bound, outside in (("min", lambda b: value < b), ("max", lambda b: value > b)):
        text = getattr(variable, bound, None)
        if text is None:
            continue
        try:
            limit = float(text)
        except ValueError:
            continue
        if outside(limit):
            raise SspError(
                f"system {system.name!r}: element {element.name!r}: parameter {name!r} = {value!r} lies outside "
                f"the {bound} {limit:g} that {fmu.name} declares"
            )


def _check_units(system: SystemStructure, units: Mapping[tuple[str, str], PortUnit]) -> None:
    """SspError naming the connection, both ports and their units when no conversion joins them (before any run)."""
    for c in system.connections:
        start = units.get((c.start_element, c.start_connector), PortUnit(""))
        end = units.get((c.end_element, c.end_connector), PortUnit(""))
        try:
            input_conversion(start, end, f"system {system.name!r}: connection {c}")
        except UnitError as error:
            raise SspError(str(error)) from None


def _check_inside(system: SystemStructure, path: Path) -> None:
    """SspError naming the element, its source and the opt-in when an element's FMU, links followed, lies outside
    the folder of the system file: an FMU is native code, so loading one from elsewhere is asked for explicitly."""
    root = system.base.resolve()
    for element in system.elements:
        fmu = system.fmu_path(element).resolve()
        if root not in fmu.parents:
            raise SspError(
                f"{path}: element {element.name!r}: source {element.source!r} lies outside the system's folder {root} "
                f"(at {fmu}); an FMU is native code, so pass --allow-outside to load FMUs from elsewhere, or put it "
                f"inside the folder"
            )


@contextmanager
def open_system(path: str | os.PathLike[str], allow_outside: bool = False) -> Iterator[SystemStructure]:
    """The system of an `.ssd` file, a folder holding `SystemStructure.ssd`, or an `.ssp` zip (extracted meanwhile,
    once, refusing members that leave the folder or unpack too large, and element sources outside the archive; the
    system's `path` and `base` then lie in the extracted folder, which is what every master must load). An `.ssd`'s
    element FMUs must lie inside its folder, links followed, unless `allow_outside`."""
    path = Path(path)
    if path.is_dir():
        path = path / SSD_NAME
    if path.suffix.lower() != ".ssp":
        system = read_ssd(path)
        if not allow_outside:
            _check_inside(system, path)
        check_against_fmus(system)
        yield system
        return
    with scratch_dir("nnfmu-ssp-") as folder:
        try:
            extract_zip(path, Path(folder))
        except ArchiveError as error:
            raise SspError(str(error)) from None
        except (OSError, zipfile.BadZipFile) as error:
            raise SspError(f"{path}: cannot open the SSP archive: {error}") from None
        ssd = Path(folder) / SSD_NAME
        if not ssd.is_file():
            raise SspError(f"{path}: the archive holds no {SSD_NAME}")
        system = read_ssd(ssd)
        for element in system.elements:
            try:
                confined_source(element.source, system.base, f"{path}: element {element.name!r}")
            except ArchiveError as error:
                raise SspError(str(error)) from None
        check_against_fmus(system)
        yield system


def _same_bytes(a: Path, b: Path) -> bool:
    """Whether two files are one (a link) or hold the same bytes."""
    if os.path.samefile(a, b):
        return True
    if a.stat().st_size != b.stat().st_size:
        return False
    with open(a, "rb") as fa, open(b, "rb") as fb:
        return all(x == y for x, y in zip(iter(lambda: fa.read(1 << 20), b""), iter(lambda: fb.read(1 << 20), b"")))


def _link(source: Path, target: Path) -> None:
    """`target` as a hard link of `source`, or a copy where a link cannot be made (another file system)."""
    try:
        os.link(source, target)
    except OSError:
        shutil.copyfile(source, target)


def local_fmu(fmu: Path, base: Path) -> Path:
    """`fmu` when it lies inside `base` (links followed); else its link or copy in `base/fmu/`, under a new name where
    another FMU of its name is there already (an nnfmu FMU carries its own step graph: no ONNX goes with it)."""
    if base.resolve() in fmu.resolve().parents:
        return fmu
    folder = base / "fmu"
    folder.mkdir(parents=True, exist_ok=True)
    for n in range(1, 1000):
        target = folder / (fmu.name if n == 1 else f"{fmu.stem}-{n}{fmu.suffix}")
        if not target.exists():
            _link(fmu, target)
        elif not _same_bytes(fmu, target):
            continue
        return target
    raise SspError(f"{folder}: 999 different FMUs named like {fmu.name} already; give the system a new folder")


def connect_by_name(
    name: str,
    vehicle: tuple[str, Path],
    components: Mapping[str, Path],
    base: Path,
    parameters: Mapping[str, Mapping[str, float]] | None = None,
) -> SystemStructure:
    """A system of one vehicle and components wired by name; FMU sources are written relative to `base`, an FMU
    outside `base` first linked (or copied) into `base/fmu/`, so that the system is self-contained (`open_system`
    loads FMUs only from inside a system's folder unless allowed).

    A component element `E` with input or output `X` connects to the vehicle's output or input named `E_X` (the
    vehicle's channel naming: element 'damper_fl', port 'velocity' -> 'damper_fl_velocity'), else to one named `X`.
    Vehicle inputs left unconnected are fed from the drive file. `parameters` maps element names to start values.
    """
    from fmpy import read_model_description

    parameters = parameters or {}

    def ports(path: Path) -> dict[str, str]:
        return {
            v.name: v.causality
            for v in read_model_description(str(path)).modelVariables
            if v.type in ("Real", "Float64") and v.causality in ("input", "output")
        }

    vehicle_name, vehicle_path = vehicle
    vehicle_path = local_fmu(Path(vehicle_path), base)
    components = {name: local_fmu(Path(path), base) for name, path in components.items()}
    vehicle_ports = ports(vehicle_path)
    elements = []
    connections = []
    for element_name, path in components.items():
        own = ports(path)
        for port, causality in own.items():
            partner = next((p for p in (f"{element_name}_{port}", port) if p in vehicle_ports), None)
            wanted = "output" if causality == "input" else "input"
            if partner is None or vehicle_ports[partner] != wanted:
                raise SspError(
                    f"system {name!r}: element {element_name!r}, connector {port!r}: the vehicle has no "
                    f"{wanted} {element_name + '_' + port!r} or {port!r} to connect it to"
                )
            if causality == "input":
                connections.append(Connection(vehicle_name, partner, element_name, port))
            else:
                connections.append(Connection(element_name, port, vehicle_name, partner))
        elements.append(
            Element(
                element_name,
                os.path.relpath(path, base),
                tuple(Connector(p, c) for p, c in own.items()),
                dict(parameters.get(element_name, {})),
            )
        )
    vehicle_connectors = tuple(Connector(p, c) for p, c in vehicle_ports.items())
    elements.insert(
        0,
        Element(
            vehicle_name,
            os.path.relpath(vehicle_path, base),
            vehicle_connectors,
            dict(parameters.get(vehicle_name, {})),
        ),
    )
    return SystemStructure(name=name, elements=elements, connections=connections, base=base)
