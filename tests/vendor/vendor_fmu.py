"""Build the vendor-style quarter car (`quarter_car.c` beside this file) into an FMI 2.0 co-simulation FMU.

Written apart from nnfmu's generators, as a user's vehicle from another tool: RK4 substeps, inputs held over the
communication step (`canInterpolateInputs="false"`), Modelica unit spellings (`m/s2`, `mm`, `kN`) declared through
`UnitDefinitions` and `TypeDefinitions`. Compiled with the host `cc` against fmpy's bundled FMI 2 headers.

Variables (value reference, causality, unit):
  inputs     zr [m] (road displacement under the tyre), F_damper [N] (damper force, > 0 resists extension)
  outputs    x_damper [m] (z_body - z_wheel, extension positive), v_damper [m/s], a_body [m/s2], a_spindle [m/s2]
             (wheel), z_body [mm], F_tyre [kN] (tyre spring force, k_t (z_wheel - zr))
  parameters m_s [kg] = 400, m_u [kg] = 40, k_s [N/m] = 20e3, k_t [N/m] = 200e3, substeps (Integer) = 4
a_body and a_spindle feed through F_damper (and a_spindle zr, F_tyre zr): the master refreshes them after a step.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import fmpy

SOURCE = Path(__file__).with_name("quarter_car.c")
IDENTIFIER = "quarter_car"
GUID = "{5e1d0a7c-vendor-quarter-car-0001}"
HEADERS = Path(fmpy.__file__).parent / "c-code"

# (name, value reference, causality, unit or declared type, start, description); units of Modelica tools
REALS = (
    ("zr", 0, "input", "m", 0.0, "road displacement under the tyre"),
    ("F_damper", 1, "input", "N", 0.0, "damper force, positive resisting extension"),
    ("x_damper", 2, "output", "m", None, "damper displacement z_body - z_wheel"),
    ("v_damper", 3, "output", "m/s", None, "damper velocity"),
    ("a_body", 4, "output", "Acceleration", None, "body acceleration"),
    ("a_spindle", 5, "output", "Acceleration", None, "wheel (spindle) acceleration"),
    ("z_body", 6, "output", "mm", None, "body displacement"),
    ("F_tyre", 7, "output", "kN", None, "tyre spring force"),
    ("m_s", 10, "parameter", "kg", 400.0, "sprung mass"),
    ("m_u", 11, "parameter", "kg", 40.0, "unsprung mass"),
    ("k_s", 12, "parameter", "N/m", 20e3, "suspension spring rate"),
    ("k_t", 13, "parameter", "N/m", 200e3, "tyre spring rate"),
)
# output -> the 1-based indices of the inputs it depends on (ModelStructure)
DEPENDENCIES = {"x_damper": "", "v_damper": "", "a_body": "2", "a_spindle": "1 2", "z_body": "", "F_tyre": "1"}
UNITS = (  # name, base-unit exponents and factor, as FMI 2 UnitDefinitions write them
    ("m", 'm="1"'),
    ("mm", 'm="1" factor="0.001"'),
    ("m/s", 'm="1" s="-1"'),
    ("mm/s", 'm="1" s="-1" factor="0.001"'),
    ("m/s2", 'm="1" s="-2"'),
    ("N", 'kg="1" m="1" s="-2"'),
    ("kN", 'kg="1" m="1" s="-2" factor="1000"'),
    ("kg", 'kg="1"'),
    ("N/m", 'kg="1" s="-2"'),
)


def model_description(velocity_unit: str = "m/s", dependencies: bool = True) -> str:
    """The FMU's modelDescription.xml text (v_damper in `velocity_unit`, m/s or mm/s; `dependencies` False leaves
    the outputs' dependencies attributes out, as many tools do: FMI reads that as depending on every known)."""
    variables, outputs = [], []
    for index, (name, vr, causality, unit, start, description) in enumerate(REALS, start=1):
        unit = velocity_unit if name == "v_damper" else unit
        variability = "fixed" if causality == "parameter" else "continuous"
        initial = ' initial="exact"' if causality == "parameter" else ""
        typed = f'declaredType="Modelica.SIunits.{unit}"' if unit == "Acceleration" else f'unit="{unit}"'
        start_attr = f' start="{start!r}"' if start is not None else ""
        variables.append(
            f'    <ScalarVariable name="{name}" valueReference="{vr}" causality="{causality}" '
            f'variability="{variability}"{initial} description="{description}">\n'
            f"      <Real {typed}{start_attr}/>\n    </ScalarVariable>"
        )
        if causality == "output":
            listed = f' dependencies="{DEPENDENCIES[name]}"' if dependencies else ""
            outputs.append(f'      <Unknown index="{index}"{listed}/>')
    variables.append(
        '    <ScalarVariable name="substeps" valueReference="0" causality="parameter" variability="fixed" '
        'initial="exact" description="RK4 substeps per communication step">\n      <Integer start="4"/>\n'
        "    </ScalarVariable>"
    )
    units = "\n".join(f'    <Unit name="{name}"><BaseUnit {base}/></Unit>' for name, base in UNITS)
    joined_outputs = "\n".join(outputs)
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="VendorQuarterCar" guid="{GUID}"
  description="vendor-style quarter car (tests/vendor)" generationTool="hand-written test model"
  variableNamingConvention="flat" numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="{IDENTIFIER}" canHandleVariableCommunicationStepSize="true"
    canInterpolateInputs="false" canGetAndSetFMUstate="false"
    canSerializeFMUstate="false" providesDirectionalDerivative="false"/>
  <UnitDefinitions>
{units}
  </UnitDefinitions>
  <TypeDefinitions>
    <SimpleType name="Modelica.SIunits.Acceleration"><Real quantity="Acceleration" unit="m/s2"/></SimpleType>
  </TypeDefinitions>
  <DefaultExperiment startTime="0" stepSize="0.001"/>
  <ModelVariables>
{chr(10).join(variables)}
  </ModelVariables>
  <ModelStructure>
    <Outputs>
{joined_outputs}
    </Outputs>
    <InitialUnknowns>
{joined_outputs}
    </InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


def build_vendor_quarter_car(folder: Path, velocity_unit: str = "m/s", dependencies: bool = True) -> Path:
    """Compile the vendor quarter car with the host `cc` and zip it into `folder`/quarter_car.fmu; return its path.
    `velocity_unit` 'mm/s' builds the variant whose v_damper is in mm/s (a connection the master must convert)."""
    scale = {"m/s": "1.0", "mm/s": "1000.0"}[velocity_unit]
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        raise RuntimeError("the vendor quarter car needs a host C compiler (cc)")
    folder.mkdir(parents=True, exist_ok=True)
    library = folder / f"{IDENTIFIER}.so"
    subprocess.run(
        [
            compiler,
            "-std=c99",
            "-O2",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-Wvla",
            "-shared",
            "-fPIC",
            f"-I{HEADERS}",
            f"-DV_DAMPER_SCALE={scale}",
            "-o",
            str(library),
            str(SOURCE),
            "-lm",
        ],
        check=True,
    )
    fmu = folder / f"{IDENTIFIER}.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("modelDescription.xml", model_description(velocity_unit, dependencies))
        archive.write(library, f"binaries/linux64/{IDENTIFIER}.so")
        archive.write(SOURCE, f"sources/{SOURCE.name}")
    library.unlink()
    return fmu
