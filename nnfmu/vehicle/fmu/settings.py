"""What `nnfmu vehicle build` builds: model, parameter file, built-in components, sample period, FMI version."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from nnfmu.fmu import BACKENDS, FMI_VERSIONS, Backend, FmiVersion
from nnfmu.vehicle.dynamics.components import CHOICES
from nnfmu.vehicle.dynamics.ports import CORNERS
from nnfmu.vehicle.fmu.errors import VehicleBuildError

MODELS = ("quarter-car", "full-vehicle")
# Internal sample period [s]: the linear part is exact at any period, the spline dampers are stepped explicitly and
# need sub-steps of at most MAX_SUBSTEP (the sub-step of `nnfmu.vehicle.dynamics.simulate`); 1e-4 s makes one sub-step
# per sample, so the FMU answers every 0.1 ms and any communication step that is a multiple of it.
DEFAULT_SAMPLE_PERIOD = 1e-4
MAX_SUBSTEP = 1e-4


@dataclass(frozen=True)
class VehicleBuildSettings:
    """`params_path` (None: the packaged mid-size sedan): a full-vehicle file, or for the quarter car also a
    quarter-car file; `components` maps a component name ('damper', 'damper_fl', 'bushing_fl_front', ...) to
    'external' (force input port, the default), 'stabilised' (force input port with the reference element's change
    over a step applied, for stiff components) or 'reference' (built-in element), `sample_period` [s] of the FMU's
    samples, FMI version, backend and the native backend's `platforms` (None: every platform a compiler here
    builds, docs/platforms.md). `corner` (fl, fr, rl, rr) is the quarter car's: None takes a quarter-car file's
    own corner, or fl of a full-vehicle file. `stabilisers` replaces a stabilised force port's reference element
    (input port name -> (stiffness, damping): N/m and N.s/m, or N.m/rad and N.m.s/rad); the element the vehicle
    keeps over a step should match the component's stiffness over a step, or the deviation it holds carries the
    difference. `initial_state` [q, q'] the FMU starts in (None: the static equilibrium on the linear reference
    elements, `initial_state`; a road test gives the rest state on the components it connects,
    `nnfmu.vehicle.dynamics.rest_state`).
    `port_derivatives`: give every stabilised force port P two more inputs, `P_per_D` and `P_per_V` (its element's
    stiffness and damping, D and V its deflection and rate outputs), used when the input `use_port_derivatives` is
    1 (a master setting them each step from the component's directional derivatives; at 0, the default, the
    fitted elements, exactly: `nnfmu.vehicle.dynamics.port_gains`).
    A stabilised port holds its reference from the start of each *sample*: sample at the communication step, or
    the stabilisation is renewed at every sample inside a step and mostly lost."""

    params_path: Path | None = None
    components: dict[str, str] = field(default_factory=dict)
    sample_period: float = DEFAULT_SAMPLE_PERIOD
    fmi_version: FmiVersion = 2
    corner: str | None = None
    backend: Backend = "native"
    platforms: tuple[str, ...] | None = None
    initial_state: tuple[float, ...] | None = None
    stabilisers: dict[str, tuple[float, float]] = field(default_factory=dict)
    port_derivatives: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.sample_period) and self.sample_period > 0.0):
            raise VehicleBuildError(f"sample period {self.sample_period!r} s must be a positive finite number")
        if self.fmi_version not in FMI_VERSIONS:
            raise VehicleBuildError(f"FMI version {self.fmi_version!r}; choose 2 or 3")
        if self.backend not in BACKENDS:
            raise VehicleBuildError(f"backend {self.backend!r}; choose one of {', '.join(BACKENDS)}")
        if self.corner is not None and self.corner not in CORNERS:
            raise VehicleBuildError(f"corner {self.corner!r}; choose one of {', '.join(CORNERS)}")
        if self.initial_state is not None and not all(math.isfinite(v) for v in self.initial_state):
            raise VehicleBuildError(f"initial state {self.initial_state!r} must hold finite numbers")
        bad_elements = {
            name: value
            for name, value in self.stabilisers.items()
            if len(value) != 2
            or not all(math.isfinite(v) and v >= 0.0 for v in value)
            or not any(v > 0.0 for v in value)
        }
        if bad_elements:
            raise VehicleBuildError(
                f"stabiliser(s) {bad_elements}: each needs (stiffness, damping), finite, >= 0 and not both 0"
            )
        bad = {name: choice for name, choice in self.components.items() if choice not in CHOICES}
        if bad:
            raise VehicleBuildError(f"component choice(s) {bad}; expected one of {', '.join(CHOICES)}")
