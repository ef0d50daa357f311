"""Settings of one `nnfmu build` run, shared by the native and the pythonfmu backend."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import onnx

from nnfmu.component import Component
from nnfmu.fmu.errors import FmuBuildError

Backend = Literal["native", "pythonfmu"]
FmiVersion = Literal[2, 3]

BACKENDS: tuple[Backend, ...] = ("native", "pythonfmu")
FMI_VERSIONS: tuple[FmiVersion, ...] = (2, 3)


@dataclass(frozen=True)
class BuildOptions:
    """What to build: `out` is the `.fmu` path (None: `exported/<ONNX file name>.fmu` from `build_fmu`,
    `exported/<model identifier>.fmu` for a graph built in memory), `name` overrides the component name,
    `filter_cutoff` [Hz] the start value of the output low-pass (None: the component's own, 0 = off), `platforms` the
    binaries of the native backend (None: every platform a compiler here builds; names as `nnfmu build --platforms`
    takes them, e.g. ("host",), ("all",) or ("x86_64-linux", "win64"): docs/platforms.md)."""

    out: Path | None = None
    backend: Backend = "native"
    fmi_version: FmiVersion = 2
    name: str | None = None
    filter_cutoff: float | None = None
    platforms: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if self.backend not in BACKENDS:
            raise FmuBuildError(f"unknown backend {self.backend!r}; choose one of {', '.join(BACKENDS)}")
        if self.fmi_version not in FMI_VERSIONS:
            raise FmuBuildError(f"unsupported FMI version {self.fmi_version!r}; choose 2 or 3")
        if self.platforms is not None and self.backend != "native":
            raise FmuBuildError(
                f"platforms apply to the native backend; the {self.backend} backend ships its runtime's own binaries"
            )
        cutoff = self.filter_cutoff
        if cutoff is not None and not (isinstance(cutoff, (int, float)) and math.isfinite(cutoff) and cutoff >= 0):
            raise FmuBuildError(f"filter cut-off {cutoff!r} Hz must be a finite number >= 0 (0 turns the filter off)")

    def component_of(self, model: onnx.ModelProto, source: str | Path) -> Component:
        """The component description the FMU is built from: the graph's, with this build's name and filter start
        value; FmuBuildError naming `source` when the graph's description cannot be read."""
        try:
            component = Component.from_onnx(model, self.name)
        except (ValueError, KeyError, TypeError) as err:  # malformed or too new `nnfmu.component` metadata
            raise FmuBuildError(f"{source}: cannot read the component description: {err}") from err
        return self.describe(component)

    def describe(self, component: Component) -> Component:
        """`component` with this build's name and filter start value, where the options set them."""
        if self.name:
            component = replace(component, name=self.name)
        return component if self.filter_cutoff is None else replace(component, filter_cutoff=float(self.filter_cutoff))
