"""Settings of one `nnfmu build` run, shared by the native and the pythonfmu backend."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from nnfmu.fmu.errors import FmuBuildError

Backend = Literal["native", "pythonfmu"]
FmiVersion = Literal[2, 3]

BACKENDS: tuple[Backend, ...] = ("native", "pythonfmu")
FMI_VERSIONS: tuple[FmiVersion, ...] = (2, 3)


@dataclass(frozen=True)
class BuildOptions:
    """What to build: `out` is the `.fmu` path (None: `exported/<name>.fmu`), `name` overrides the component name,
    `platforms` the binaries of the native backend (None: this machine's, plus win64 when its cross compiler is
    installed; names as `nnfmu build --platforms` takes them, e.g. ("linux64", "win64"))."""

    out: Path | None = None
    backend: Backend = "native"
    fmi_version: FmiVersion = 2
    name: str | None = None
    platforms: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if self.backend not in BACKENDS:
            raise FmuBuildError(f"unknown backend {self.backend!r}; choose one of {', '.join(BACKENDS)}")
        if self.fmi_version not in FMI_VERSIONS:
            raise FmuBuildError(f"unsupported FMI version {self.fmi_version!r}; choose 2 or 3")
        if self.platforms is not None and self.backend != "native":
            raise FmuBuildError(f"platforms apply to the native backend; the {self.backend} backend ships its "
                                "runtime's own binaries")
