"""The system FMU's modelDescription.xml (FMI 2.0 or 3.0 co-simulation), written with ElementTree so any name is
escaped: the drive as inputs (value references 0..), every part's Real outputs as outputs, every part's Real
parameters as `element.parameter`, units defined with their SI exponents where nnfmu knows them; FMI 3 adds the
independent variable `time` (the value reference after the parameters)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from nnfmu.cosim.container.plan import SystemPlan, Variable
from nnfmu.fmu import GENERATION_TOOL, SI_EXPONENTS

SOURCES = {2: ("system_fmu.c", "inner_loop.c"), 3: ("system_fmu3.c", "inner_loop.c")}  # compiled, per FMI version


def _number(value: float) -> str:
    return repr(float(value))


def render_model_description(plan: SystemPlan, identifier: str, guid: str, default_step: float, fmi: int = 2) -> str:
    """The XML text of the system FMU's model description for FMI `fmi` (2 or 3)."""
    root = ET.Element(
        "fmiModelDescription",
        {
            "fmiVersion": f"{fmi}.0",
            "modelName": plan.name,
            "guid" if fmi == 2 else "instantiationToken": guid,
            "description": f"system {plan.name}: {', '.join(p.name for p in plan.parts)} stepped by nnfmu's master "
            f"at {plan.inner_step:g} s ({plan.settings.scheme})",
            "generationTool": GENERATION_TOOL,
            "variableNamingConvention": "flat",
        }
        | ({"numberOfEventIndicators": "0"} if fmi == 2 else {}),
    )
    serializes = plan.states and plan.serializes
    if fmi == 2:
        cs = ET.SubElement(
            root,
            "CoSimulation",
            {
                "modelIdentifier": identifier,
                "canHandleVariableCommunicationStepSize": "true",
                "canInterpolateInputs": "true",
                "maxOutputDerivativeOrder": "0",
                "canGetAndSetFMUstate": "true" if plan.states else "false",
                "canSerializeFMUstate": "true" if serializes else "false",
                "providesDirectionalDerivative": "false",
                "canNotUseMemoryManagementFunctions": "true",
            },
        )
        files = ET.SubElement(cs, "SourceFiles")
        for name in SOURCES[2]:
            ET.SubElement(files, "File", {"name": name})
    else:
        ET.SubElement(
            root,
            "CoSimulation",
            {
                "modelIdentifier": identifier,
                "canHandleVariableCommunicationStepSize": "true",
                "canGetAndSetFMUState": "true" if plan.states else "false",
                "canSerializeFMUState": "true" if serializes else "false",
                "providesDirectionalDerivatives": "false",
                "hasEventMode": "false",
            },
        )
    variables = [*plan.inputs, *plan.outputs, *plan.parameters]
    units = list(dict.fromkeys([*(["s"] if fmi == 3 else []), *(v.unit for v in variables if v.unit)]))
    if units:
        definitions = ET.SubElement(root, "UnitDefinitions")
        for unit in units:
            element = ET.SubElement(definitions, "Unit", {"name": unit})
            exponents = SI_EXPONENTS.get(unit)
            if exponents is not None:
                ET.SubElement(element, "BaseUnit", {base: str(e) for base, e in exponents})
    categories = ET.SubElement(root, "LogCategories")
    for name, text in (
        ("logEvents", "what the system FMU and its parts report (needs logging on)"),
        ("logStatusWarning", "warnings of the system FMU and its parts"),
        ("logStatusError", "refused calls and a part's failure, named; always reported"),
    ):
        ET.SubElement(categories, "Category", {"name": name, "description": text})
    experiment = {"startTime": _number(plan.start_time), "stepSize": _number(default_step)}
    if plan.stop_time is not None:
        experiment["stopTime"] = _number(plan.stop_time)
    ET.SubElement(root, "DefaultExperiment", experiment)
    model_variables = ET.SubElement(root, "ModelVariables")
    reference = 0
    groups = (("input", plan.inputs), ("output", plan.outputs), ("parameter", plan.parameters))
    end = sum(len(group) for _, group in groups)
    if fmi == 3:
        attributes = {"name": "time", "valueReference": str(end), "causality": "independent"}
        ET.SubElement(model_variables, "Float64", attributes | {"variability": "continuous", "unit": "s"})
    for causality, group in groups:
        for variable in group:
            _scalar(model_variables, variable, reference, causality, fmi)
            reference += 1
    structure = ET.SubElement(root, "ModelStructure")
    first_output = len(plan.inputs)
    if fmi == 2:
        outputs = ET.SubElement(structure, "Outputs")
        for i in range(len(plan.outputs)):  # index: 1-based in ModelVariables
            ET.SubElement(outputs, "Unknown", {"index": str(first_output + i + 1), "dependencies": ""})
        initial = ET.SubElement(structure, "InitialUnknowns")
        for i in range(len(plan.outputs)):
            ET.SubElement(initial, "Unknown", {"index": str(first_output + i + 1)})
    else:
        for i in range(len(plan.outputs)):
            ET.SubElement(structure, "Output", {"valueReference": str(first_output + i), "dependencies": ""})
        for i in range(len(plan.outputs)):
            ET.SubElement(structure, "InitialUnknown", {"valueReference": str(first_output + i)})
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _scalar(parent: ET.Element, variable: Variable, reference: int, causality: str, fmi: int) -> None:
    """One variable (FMI 2 ScalarVariable with Real, FMI 3 Float64): inputs start at 0, outputs are calculated,
    parameters fixed with their start value."""
    attributes = {
        "name": variable.name,
        "valueReference": str(reference),
        "description": variable.description,
        "causality": causality,
        "variability": "fixed" if causality == "parameter" else "continuous",
    }
    if causality == "output":
        attributes["initial"] = "calculated"
    real = {"unit": variable.unit} if variable.unit else {}
    if causality == "input":
        real["start"] = "0.0"
    elif causality == "parameter":
        real["start"] = _number(variable.start)
    if fmi == 3:
        ET.SubElement(parent, "Float64", attributes | real)
    else:
        ET.SubElement(ET.SubElement(parent, "ScalarVariable", attributes), "Real", real)
