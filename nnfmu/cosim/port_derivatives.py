"""Port derivatives: an element's inputs that take, every communication step, a connected component's local
derivative from its FMU's directional derivatives (nnfmu's stabilised vehicle ports taking the bushing networks'
local stiffness and damping instead of the elements fitted once).

The convention is by name, so the master needs to know nothing of vehicles: an element V with an input named
`P_per_D` and an input `use_port_derivatives`, whose input P is fed by output F of a component C and whose output D
feeds C's input I, gets dP/dD = dF/dI (`fmi2GetDirectionalDerivative` / `fmi3GetDirectionalDerivative` of C at its
latest communication point, times the unit conversions of both connections) after every step of C and before V's
refresh, and `use_port_derivatives` = 1 once at the start. The inputs are never connected; with this off, or a
component that provides no directional derivatives, they stay at their start values (0: nnfmu's vehicle then keeps
its fitted elements exactly). A derivative that is not finite, or a call that fails, at the start stops the run
naming the element and port; later it keeps the last finite value (the vehicle also clamps negative values to 0).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from nnfmu.cosim.direct import RealBlock
from nnfmu.cosim.slave import FmuSlave
from nnfmu.errors import NnfmuError

USE = "use_port_derivatives"
PER = "_per_"


class PortDerivativeError(NnfmuError, ValueError):
    """A component's directional derivative for a port derivative input cannot be had at the start of a run."""


@dataclass(frozen=True)
class Link:
    """One connection with its conversions: row = s * output + o, input = a * row + b."""

    source: str
    output: str
    target: str
    input: str
    s: float
    a: float


@dataclass(frozen=True)
class _Derivative:
    """dF/dI of `component` for `element`'s input `name` (value references and the connections' scale)."""

    element: str
    name: str
    component: str
    unknown: int
    known: int
    scale: float


def port_derivative_inputs(slaves: Mapping[str, FmuSlave], links: Sequence[Link]) -> dict[str, list[_Derivative]]:
    """Per element, its port derivative inputs found by the naming rule (the element must also have
    `use_port_derivatives`); components named but not providing derivatives included (see `provides`)."""
    found: dict[str, list[_Derivative]] = {}
    for name, slave in slaves.items():
        inputs = set(slave.names("input"))
        if USE not in inputs:
            continue
        for force in (link for link in links if link.target == name):
            for motion in (link for link in links if link.source == name and link.target == force.source):
                gain = f"{force.input}{PER}{motion.output}"
                if gain not in inputs:
                    continue
                component = slaves[force.source]
                unknown, known = component.value_references([force.output, motion.input])
                scale = force.a * force.s * motion.a * motion.s
                found.setdefault(name, []).append(_Derivative(name, gain, force.source, unknown, known, scale))
    return found


def derivative_inputs(inputs: Sequence[str]) -> set[str]:
    """The inputs among an element's `inputs` that the port-derivative rule may set (none without `USE`)."""
    return {n for n in inputs if n == USE or PER in n} if USE in inputs else set()


def exempt_inputs(slaves: Mapping[str, FmuSlave]) -> set[tuple[str, str]]:
    """(element, input) of every input the port-derivative rule may set: never connected, never refused as free."""
    return {(name, n) for name, slave in slaves.items() for n in derivative_inputs(slave.names("input"))}


def provides(slave: FmuSlave) -> bool:
    """The FMU declares directional derivatives (FMI 2 `providesDirectionalDerivative`, FMI 3 `...Derivatives`)."""
    return bool(getattr(slave.description.coSimulation, "providesDirectionalDerivative", False))


class PortDerivatives:
    """The port derivative inputs a run sets: `start` once after initialisation, `update` after each pass."""

    def __init__(self, slaves: Mapping[str, FmuSlave], links: Sequence[Link]) -> None:
        found = port_derivative_inputs(slaves, links)
        self.slaves = slaves
        self.derivatives = {
            name: [d for d in items if provides(slaves[d.component])]
            for name, items in found.items()
            if all(provides(slaves[d.component]) for d in items)
        }
        self.blocks = {
            name: RealBlock(slaves[name], [d.name for d in items]) for name, items in self.derivatives.items()
        }

    @property
    def active(self) -> bool:
        return bool(self.derivatives)

    def names(self) -> list[str]:
        """'element.input' of every input set, for the run's notes."""
        return [f"{d.element}.{d.name}" for items in self.derivatives.values() for d in items]

    def start(self) -> None:
        """`use_port_derivatives` = 1 and the first values; PortDerivativeError for a value not to be had."""
        for name, items in self.derivatives.items():
            self.slaves[name].set_real([USE], [1.0])
            block = self.blocks[name]
            for i, d in enumerate(items):
                value = self._derivative(d)
                if not math.isfinite(value):
                    raise PortDerivativeError(
                        f"element {d.component!r} gives no finite directional derivative for {name}.{d.name} at the "
                        f"start ({value!r}); build the vehicle without port derivatives or fix the component"
                    )
                block.values[i] = value
            block.set()

    def update(self) -> None:
        """Every port derivative input from its component's current derivative (the last finite one kept)."""
        for name, items in self.derivatives.items():
            block = self.blocks[name]
            for i, d in enumerate(items):
                value = self._derivative(d)
                if math.isfinite(value):
                    block.values[i] = value
            block.set()

    def _derivative(self, d: _Derivative) -> float:
        """dF/dI of the component times the connections' scale; NaN where the call fails."""
        try:  # fmpy's FMI 2 and FMI 3 calls take (unknowns, knowns, seed) alike
            value = self.slaves[d.component].fmu.getDirectionalDerivative([d.unknown], [d.known], [1.0])[0]
        except Exception:  # noqa: BLE001 (an FMI error status: fmpy raises its own exception class)
            return float("nan")
        return float(np.float64(value) * d.scale)
