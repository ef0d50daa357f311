"""Network FMUs replayed open loop along a reference's motion of their element: the road test budget's network error.

A network's own error, with no coupling in it: its FMU fed the monolithic reference's motion of the element it stands
for (`open_loop_replay`) and compared with the reference's truth-physics outputs there (`network_errors`, the
budget's `nrmse_network`).
"""

from __future__ import annotations

from pathlib import Path

from fmpy import read_model_description

from nnfmu.cosim import replay_fmu
from nnfmu.data import Measurement
from nnfmu.validate import ChannelComparison, ValidationSettings, compare
from nnfmu.workflows.roadtest.systems import ComponentFmus, bushing_elements, damper_elements


def fmu_ports(fmu: Path, causality: str) -> dict[str, str]:
    """Real variables of `fmu` with `causality`, name -> unit."""
    return {
        v.name: v.unit or ""
        for v in read_model_description(str(fmu)).modelVariables
        if v.causality == causality and v.type in ("Real", "Float64")
    }


def open_loop_replay(fmu: Path, reference: Measurement, element: str) -> Measurement:
    """The FMU of `element` replayed along the reference's motion of that element (its inputs `element_<input>`);
    outputs named `element_<output>`."""
    inputs = fmu_ports(fmu, "input")
    motion = Measurement(
        reference.time,
        {name: reference[f"{element}_{name}"] for name in inputs},
        inputs,
        source=f"{element} motion in {reference.source}",
    )
    replayed = replay_fmu(fmu, motion)
    return Measurement(
        replayed.time,
        {f"{element}_{k}": v for k, v in replayed.channels.items()},
        {f"{element}_{k}": u for k, u in replayed.units.items()},
        source=f"{fmu.name} replayed on the {element} motion",
    )


def network_errors(
    system: str,
    model: str,
    fmus: ComponentFmus,
    ref: Measurement,
    cosim: Measurement,
    truth: Measurement,
    channels: list[str],
    validation: ValidationSettings,
) -> dict[str, ChannelComparison]:
    """Each channel's network error (`budget`): a network's output replayed open loop along the reference motion of
    its element against the reference, else the network co-simulation against the truth co-simulation."""
    networks = {element: fmus.dampers[model] for element in damper_elements(system)}
    networks |= {element: fmus.bushing for element in bushing_elements(system) if fmus.bushing is not None}
    found: dict[str, ChannelComparison] = {}
    for element, fmu in networks.items():
        outputs = fmu_ports(fmu, "output")
        mine = [c for c in channels if c.startswith(f"{element}_") and c.removeprefix(f"{element}_") in outputs]
        if mine:
            found |= {c.name: c for c in compare(open_loop_replay(fmu, ref, element), ref, mine, validation)}
    rest = [c for c in channels if c not in found]
    found |= {c.name: c for c in compare(cosim, truth, rest, validation)} if rest else {}
    return found
