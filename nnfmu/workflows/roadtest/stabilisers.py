"""The stabilised bushing ports' reference elements, fitted to the bushing component the vehicle is coupled with.

Over a step the vehicle applies the component force set at the step start plus its reference element's change,
S (x(t) - x_k) (`nnfmu.vehicle.dynamics.linear`): what the component's force changes beyond that within the step
is held, one step late. The parameter file's linear bushing is not the component's stiffness over a step: the rig
physics add Maxwell branches and friction to the elastic rate, and one set of networks (the front bushing's)
serves the softer rear bushings too. The deviation then carries a stiffness the exact step does not see, which
shifted the LCA's ~25 Hz fore-aft mode in the road test (front axial bushing force 2.9 % NRMSE from the coupling
alone, pseudo-damage ratio 1.25-1.29). Here each channel's element is the component's own incremental stiffness
and damping: the least-squares fit of dF = k dx + c dv between consecutive samples of the component's step graph
run along its reference stimulus (held-out rig inputs it carries for its self-check, `nnfmu.reference_stimulus`),
so no knowledge of the truth physics enters.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import onnx

from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.export.step_runner import run_step_graph
from nnfmu.reference_stimulus import ReferenceStimulus

MIN_SAMPLES = 20  # fewer consecutive samples than this fit no element


def incremental_element(position: np.ndarray, rate: np.ndarray, force: np.ndarray) -> tuple[float, float] | None:
    """(stiffness, damping) of the least-squares fit dF = k dx + c dv over consecutive samples of one channel, or
    None where it is no passive element (k <= 0 or c < 0), the record is too short or its motion degenerate."""
    columns = np.column_stack([np.diff(position), np.diff(rate)])
    if len(columns) < MIN_SAMPLES or not np.all(np.isfinite(columns)) or np.linalg.matrix_rank(columns) < 2:
        return None
    (stiffness, damping), *_ = np.linalg.lstsq(columns, np.diff(force), rcond=None)
    if not (np.isfinite(stiffness) and np.isfinite(damping) and stiffness > 0.0 and damping >= 0.0):
        return None
    return float(stiffness), float(damping)


def bushing_stabilisers(bushing: onnx.ModelProto, elements: Sequence[str]) -> dict[str, tuple[float, float]]:
    """The vehicle's stabiliser elements ('bushing_fl_front_radial_force' -> (stiffness, damping)) for `elements`
    coupled with the bushing step graph `bushing`, fitted along its reference stimulus per channel it computes;
    empty (the parameter file's elements stay) when the graph carries no stimulus."""
    stimulus = ReferenceStimulus.from_onnx(bushing)
    if stimulus is None:
        return {}
    inputs = {name: np.asarray(values, dtype=float) for name, values in stimulus.inputs.items()}
    outputs = run_step_graph(bushing, inputs)
    fitted = {}
    for channel in BUSHING_CHANNELS.values():
        if not {channel.position, channel.rate} <= set(inputs) or channel.force not in outputs:
            continue
        element = incremental_element(inputs[channel.position], inputs[channel.rate], outputs[channel.force])
        if element is not None:
            fitted[channel.force] = element
    return {f"{name}_{force}": element for name in elements for force, element in fitted.items()}
