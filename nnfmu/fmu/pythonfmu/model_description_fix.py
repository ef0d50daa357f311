"""Complete the model description pythonfmu (FMI 2.0) or pythonfmu3 (FMI 3.0) writes, so it matches the native one.

Neither runtime knows units, the sample period or which inputs an output depends on; pythonfmu 0.7.0 also omits
`ModelStructure/InitialUnknowns` (fmpy's validator rejects that) and pythonfmu3 0.3.4 writes
`canHandleVariableCommunicationStepSize` from another option's value. This post-processor checks the runtime's
variables against nnfmu's variable table (same names, value references, causalities, types) and fills in the rest
from the same `ModelDescriptionView` the native backend renders, so units and dependencies cannot differ between
backends. It never renumbers anything.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

from nnfmu.fmu.model_description import ModelDescriptionView
from nnfmu.fmu.names import xml_text
from nnfmu.fmu.pythonfmu.errors import PythonFmuBuildError
from nnfmu.fmu.sampling import annotate_sample_period
from nnfmu.fmu.step_graph import annotate_step_graph
from nnfmu.fmu.variables import FmuVariable

# the order of the elements of fmiModelDescription, per FMI version
_ORDER = {
    2: (
        "CoSimulation",
        "UnitDefinitions",
        "TypeDefinitions",
        "LogCategories",
        "DefaultExperiment",
        "VendorAnnotations",
        "ModelVariables",
        "ModelStructure",
    ),
    3: (
        "CoSimulation",
        "UnitDefinitions",
        "TypeDefinitions",
        "LogCategories",
        "DefaultExperiment",
        "ModelVariables",
        "ModelStructure",
        "Annotations",
    ),
}
_FMI3_TYPES = {"Real": "Float64", "Boolean": "Boolean"}


@dataclass(frozen=True)
class DescriptionFix:
    """What the runtime cannot know: nnfmu's view of the FMU (variables, units, dependencies), the texts to show and
    the CoSimulation capability flags the slave supports."""

    view: ModelDescriptionView
    description: str
    generation_tool: str
    capabilities: dict[str, bool]


def fix_model_description(root: ET.Element, fix: DescriptionFix) -> ET.Element:
    """Check the runtime's `root` against `fix.view`; add units, dependencies and the default step in place."""
    version = fix.view.identity.fmi_version
    if root.get("fmiVersion") != f"{version}.0":
        raise PythonFmuBuildError(f"the runtime wrote FMI {root.get('fmiVersion')}, expected {version}.0")
    scalars = root.find("ModelVariables")
    if scalars is None:
        raise PythonFmuBuildError("the runtime's model description has no ModelVariables")
    by_vr = _check_variables(list(scalars), fix.view)
    root.set("modelName", fix.view.model_name)
    root.set("description", xml_text(fix.description))
    root.set("generationTool", fix.generation_tool)
    root.attrib.pop("generationDateAndTime", None)  # optional; without it the same inputs give the same FMU bytes
    _set_capabilities(root, fix.capabilities)
    for child in list(scalars):
        scalars.remove(child)
    for var in fix.view.variables:  # the native backend's order (FMI 3: `time` first, whatever its reference)
        element = by_vr[var.value_reference]
        _complete_variable(element, element[0] if version == 2 else element, var)
        scalars.append(element)
    _add_units(root, fix.view)
    _add_default_experiment(root, fix.view.sample_period)
    if fix.view.sample_period is not None:
        annotate_sample_period(root, fix.view.sample_period, version)
    if fix.view.step_graph is not None:
        annotate_step_graph(root, fix.view.step_graph, version)
    _add_model_structure(root, fix.view)
    _sort_children(root, _ORDER[version])
    return root


def _element_key(element: ET.Element, version: int) -> tuple[str | None, str | None, str | None, str | None]:
    """(name, value reference, causality, table type) of a ScalarVariable (FMI 2) or typed variable (FMI 3)."""
    if version == 2:
        kind = element[0].tag if len(element) else None
    else:
        kind = next((t for t, tag in _FMI3_TYPES.items() if tag == element.tag), element.tag)
    return element.get("name"), element.get("valueReference"), element.get("causality"), kind


def _check_variables(elements: list[ET.Element], view: ModelDescriptionView) -> dict[int, ET.Element]:
    """The runtime must list exactly nnfmu's variables with the same references, causalities and types; return
    its elements by value reference."""
    version = view.identity.fmi_version
    expected = sorted((v.name, str(v.value_reference), v.causality, v.type) for v in view.variables)
    found = [_element_key(e, version) for e in elements]
    if sorted(found, key=str) != sorted(expected, key=str):
        raise PythonFmuBuildError(f"the runtime's variables {found} differ from nnfmu's variable table {expected}")
    return {int(e.get("valueReference")): e for e in elements}


def _set_capabilities(root: ET.Element, capabilities: dict[str, bool]) -> None:
    """Write the slave's CoSimulation flags explicitly, whatever the runtime derived them from."""
    cosimulation = root.find("CoSimulation")
    if cosimulation is None:
        raise PythonFmuBuildError("the runtime's model description has no CoSimulation element")
    for flag, value in capabilities.items():
        cosimulation.set(flag, "true" if value else "false")


def _complete_variable(variable: ET.Element, value: ET.Element, var: FmuVariable) -> None:
    """Set the (XML-safe) description on the variable, the unit and, for the cut-off, its bound on the element
    holding the value (FMI 2: the `Real` child of the ScalarVariable; FMI 3: the variable itself)."""
    if var.description:
        variable.set("description", var.description)
    if var.unit:
        value.set("unit", var.unit)
    if var.name == "filter_cutoff":
        value.set("min", "0")  # the slave refuses a negative cut-off


def _add_units(root: ET.Element, view: ModelDescriptionView) -> None:
    """Declare every unit used, with its SI base-unit exponents where nnfmu knows them."""
    if not view.units:
        return
    definitions = ET.SubElement(root, "UnitDefinitions")
    for unit in view.units:
        element = ET.SubElement(definitions, "Unit", name=unit.name)
        if unit.exponents is not None:
            ET.SubElement(element, "BaseUnit", {base: str(exponent) for base, exponent in unit.exponents})


def _add_default_experiment(root: ET.Element, sample_period: float | None) -> None:
    """Start at 0 and suggest the sample period as the communication step (a master may choose any other)."""
    experiment = root.find("DefaultExperiment")
    if experiment is None:
        experiment = ET.SubElement(root, "DefaultExperiment")
    experiment.set("startTime", "0")
    if sample_period is not None:
        experiment.set("stepSize", repr(float(sample_period)))


def _add_model_structure(root: ET.Element, view: ModelDescriptionView) -> None:
    """Outputs depend on no input at a communication point (they change only in doStep); initial unknowns list, for
    every output, the inputs its tensor is computed from and `output_gain` (sample 0 is evaluated at initialisation).
    FMI 2 names variables by index, FMI 3 by value reference."""
    structure = root.find("ModelStructure")
    if structure is not None:
        root.remove(structure)
    structure = ET.SubElement(root, "ModelStructure")
    if view.identity.fmi_version == 2:
        listed = ET.SubElement(structure, "Outputs")
        for var in view.outputs:
            ET.SubElement(listed, "Unknown", index=str(view.index(var)), dependencies="")
        initial = ET.SubElement(structure, "InitialUnknowns")
        for var in view.outputs:
            ET.SubElement(initial, "Unknown", index=str(view.index(var)), **_dependencies(view, var))
        return
    for var in view.outputs:
        ET.SubElement(structure, "Output", valueReference=str(var.value_reference), dependencies="")
    for var in view.outputs:
        ET.SubElement(structure, "InitialUnknown", valueReference=str(var.value_reference), **_dependencies(view, var))


def _dependencies(view: ModelDescriptionView, var: FmuVariable) -> dict[str, str]:
    """The `dependencies` attribute of an initial unknown; none when it depends on too many knowns to list."""
    keys = view.initial_dependencies(var)
    return {} if keys is None else {"dependencies": keys}


def _sort_children(root: ET.Element, order: tuple[str, ...]) -> None:
    """Reorder fmiModelDescription's children into the sequence the FMI schema requires."""
    children = list(root)
    unknown = [c.tag for c in children if c.tag not in order]
    if unknown:
        raise PythonFmuBuildError(f"unexpected elements in the runtime's model description: {unknown}")
    for child in children:
        root.remove(child)
    root.extend(sorted(children, key=lambda c: order.index(c.tag)))
