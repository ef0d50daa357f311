"""Did a co-simulation drive a network outside what it was trained on? One warning line per network input whose
signal left the training envelope its FMU carries (the step graph inside the FMU, `nnfmu.fmu.step_graph`), or moved
with much more of its power above the band its training record excited than the record did.

A network's error in a car is its error on the car's motion: where a pothole drives a damper past the dyno
program's peak velocity the network extrapolates, and that share of the run is where the vehicle result is worst.
The user learns it from the run itself, before blaming the coupling or the step.
"""

from __future__ import annotations

import numpy as np

from nnfmu.component import Component
from nnfmu.cosim import DriveBinding
from nnfmu.data import Measurement
from nnfmu.export import ExportError
from nnfmu.export.band import carried_band
from nnfmu.fmu import StepGraphError
from nnfmu.workflows.roadtest.envelope import above_band_text, beyond_range_text, excursion
from nnfmu.workflows.system import VirtualSystem


def _carried_component(system: VirtualSystem, element: str) -> Component | None:
    """The component description of the step graph `element`'s FMU carries; None for an FMU without one."""
    try:
        return system.component(element)
    except StepGraphError:
        return None  # an altered or unreadable graph: the run used the FMU's own binary, nothing to compare


def _channel(binding: DriveBinding, element: str, connector: str) -> str:
    """The result channel an output is recorded under (the driven element's by name, the others' element_output)."""
    return connector if element == binding.element else f"{element}_{connector}"


def training_range_lines(system: VirtualSystem, result: Measurement) -> list[str]:
    """A line per network input whose signal in `result` (a run on the system's drive binding) left its training
    envelope (the range reached, how far past the envelope, on what share of the run and from when) or ran above the
    band its training record excited (`Excursion.above_band`); a line per element whose carried band
    cannot be read."""
    lines = []
    binding = system.drive_binding()
    feeds = {
        (c.end_element, c.end_connector): (c.start_element, c.start_connector) for c in system.structure.connections
    }
    for element in system.structure.elements:
        component = _carried_component(system, element.name)
        if component is None:
            continue
        try:
            band = carried_band(component)
        except ExportError as err:
            lines.append(f"element {element.name!r}: {err}; its inputs' frequencies were not checked")
            band = {}
        for port in component.inputs:
            source = feeds.get((element.name, port.name))
            channel = None if source is None else _channel(binding, *source)
            if channel is None or channel not in result.channels:
                continue
            signal = result[channel]
            edge = band.get(port.name)
            used = excursion("cosim", element.name, port, signal, edge, result.sample_period)
            if used.share_outside > 0.0:
                outside = (signal < used.envelope_min) | (signal > used.envelope_max)
                first = float(result.time[np.flatnonzero(outside)[0]])
                lines.append(
                    f"element {element.name!r}: input {port.name!r} {beyond_range_text(used)} (first at "
                    f"{first:.4g} s): the network extrapolates there and the result is least trustworthy there; train "
                    "on a record that covers the range"
                )
            if used.above_band:
                lines.append(
                    f"element {element.name!r}: input {port.name!r} {above_band_text(used)}; train on a record whose "
                    "drive reaches the frequencies of the run"
                )
    return lines
