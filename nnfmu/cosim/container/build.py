"""Build a system FMU: plan the system, copy its parts' unpacked FMUs under resources/fmus/, write the C master's
configuration and the model description, compile `templates/c/system_fmu.c` with the master's loop
(`templates/c/inner_loop.c`) for every platform chosen that all its parts carry a binary for, and zip it all
atomically."""

from __future__ import annotations

import hashlib
import shutil
import uuid
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

from nnfmu.atomic import scratch_dir
from nnfmu.cosim.binding import DriveBinding
from nnfmu.cosim.container.config import CONFIG_NAME, render_config
from nnfmu.cosim.container.model_description import SOURCES, render_model_description
from nnfmu.cosim.container.plan import Part, SystemPlan, plan_system
from nnfmu.cosim.master import CosimError, CosimSettings
from nnfmu.cosim.ssp import SystemStructure
from nnfmu.fmu import GENERATION_TOOL, c_identifier, render_build_description
from nnfmu.resources import templates_dir

if TYPE_CHECKING:
    from nnfmu.fmu import Target

HEADERS = ("inner_loop.h", "system_fmu.c")  # system_fmu.c: compiled for FMI 2, included by system_fmu3.c
FMI_HEADERS = (
    "fmi2Functions.h",
    "fmi2FunctionTypes.h",
    "fmi2TypesPlatform.h",
    "fmi3Functions.h",
    "fmi3FunctionTypes.h",
    "fmi3PlatformTypes.h",
)
DEFINES = ("-DNN_LOOP_HIDDEN",)  # the loop's functions stay inside the library: only the FMI functions are exported
LIBRARIES = {".so": ("-lm", "-ldl"), ".dll": ("-lm",), ".dylib": ("-lm",)}  # by library suffix: dlopen is libdl's


def _guid(plan: SystemPlan, identifier: str, fmi: int) -> str:
    """A GUID-shaped token from the plan (its parts' GUIDs among it), the FMI version and the generator: same system,
    same token."""
    digest = hashlib.sha256(f"{GENERATION_TOOL}\0{identifier}\0fmi{fmi}\0{plan!r}".encode())
    return "{" + str(uuid.UUID(bytes=digest.digest()[:16], version=4)) + "}"


def build_system_fmu(
    system: SystemStructure,
    out: Path,
    step: float,
    inner_step: float | None = None,
    settings: CosimSettings | None = None,
    binding: DriveBinding | None = None,
    fmi: int = 2,
    extrapolate_drive: bool = True,
    platforms: tuple[str, ...] | None = None,
) -> SystemPlan:
    """Write the system FMU of `system` to `out` (a .fmu, replaced atomically) with the default communication step
    `step` [s] and the inner step `inner_step` [s] (None: `step`); `settings` pick the scheme (its step is ignored),
    `binding` the drive inputs (None: the one element with free inputs), `fmi` the system FMU's FMI version (2 or 3;
    its parts may be either); `extrapolate_drive`: without input derivatives from the outer master, the drive over a
    step follows its slope over the step before (False: held); `platforms` as `nnfmu build --platforms` (None: its
    default), each built only where every part carries a binary for it, those left out named in one
    PlatformSkippedWarning. Returns the plan. CosimError naming the element or setting that cannot be built (a part
    without a binary for any platform asked); CompilerError without a compiler for them."""
    from nnfmu.fmu import (
        PlatformSkippedWarning,
        compile_shared_library,
        fmi_headers_dir,
        package_fmu,
        select_targets,
    )

    if fmi not in SOURCES:
        raise CosimError(f"FMI version {fmi!r}: a system FMU is FMI 2 or 3")
    inner = step if inner_step is None else inner_step
    for name, value in (("step", step), ("inner step", inner)):
        if not (value > 0 and value < float("inf")):
            raise CosimError(f"{name} {value!r} must be a positive number of seconds")
    whole = round(step / inner)
    if inner > step * (1 + 1e-9) or abs(whole * inner - step) > 1e-6 * inner:
        raise CosimError(f"the step {step:g} s must be a whole multiple of the inner step {inner:g} s")
    settings = CosimSettings(port_derivatives=False) if settings is None else settings
    identifier = c_identifier(out.stem)
    targets, skipped = select_targets(platforms)
    with scratch_dir("nnfmu-system-fmu-") as scratch:
        tree = Path(scratch) / "fmu"
        carried = tuple(t.platform for t in targets)
        plan = plan_system(system, settings, inner, binding, tree / "resources", extrapolate_drive, carried)
        buildable, lacking = [], []
        for target in targets:
            missing = next((p for p in plan.parts if not _has_binary(tree / "resources", p, target)), None)
            if missing is None:
                buildable.append(target)
            else:
                lacking.append(f"{target.name} (element {missing.name!r} has no binary for it)")
        if not buildable:
            raise CosimError(f"no platform asked for has a binary in every part: {'; '.join(lacking)}")
        guid = _guid(plan, identifier, fmi)
        sources = tree / "sources"
        sources.mkdir(parents=True)
        for name in dict.fromkeys((*SOURCES[fmi], *HEADERS)):
            shutil.copyfile(templates_dir() / "c" / name, sources / name)
        for name in FMI_HEADERS:
            shutil.copyfile(fmi_headers_dir() / name, sources / name)
        (sources / CONFIG_NAME).write_text(render_config(plan, identifier, guid), "utf-8")
        description = render_model_description(plan, identifier, guid, step, fmi)
        (tree / "modelDescription.xml").write_text(description, "utf-8")
        if fmi == 3:
            (sources / "buildDescription.xml").write_text(_build_description(identifier), "utf-8")
        for target in buildable:
            compile_shared_library(
                target,
                [sources / name for name in SOURCES[fmi]],
                sources,
                tree / "binaries" / target.folder(fmi) / f"{identifier}{target.suffix}",
                defines=DEFINES,
                libraries=LIBRARIES[target.suffix],
            )
        package_fmu(tree, out)
    left_out = [skipped] if skipped else []
    if lacking:
        left_out.append("no system FMU binary for " + ", ".join(lacking))
    if left_out:
        warnings.warn("; ".join(left_out), PlatformSkippedWarning, stacklevel=2)
    return plan


def _build_description(identifier: str) -> str:
    """sources/buildDescription.xml: one configuration per FMI 3 platform, each linking `LIBRARIES` of its suffix
    (libdl on Linux, where glibc before 2.34 keeps dlopen)."""
    from nnfmu.fmu import PLATFORMS

    libraries = {p.name: tuple(flag.removeprefix("-l") for flag in LIBRARIES[p.suffix]) for p in PLATFORMS}
    return render_build_description(identifier, list(SOURCES[3]), libraries)


def _has_binary(resources: Path, part: Part, target: Target) -> bool:
    """The part's copied FMU carries its library for `target`'s platform."""
    folder = resources / part.folder / "binaries" / target.folder(part.fmi_version)
    return (folder / f"{part.identifier}{target.suffix}").is_file()
