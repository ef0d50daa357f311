"""Port derivatives: an element's inputs that take, every communication step, a connected component's local
derivative from its FMU's directional derivatives (nnfmu's stabilised vehicle ports taking the bushing networks'
local stiffness and damping instead of the elements fitted once).

The convention is by name, so the master needs to know nothing of vehicles: an element V with inputs named
`P_per_D` and `P_per_D_given`, whose input P is fed by output F of a component C and whose output D feeds C's input
I, gets dP/dD = dF/dI (`fmi2GetDirectionalDerivative` / `fmi3GetDirectionalDerivative` of C at its latest
communication point, times the unit conversions of both connections) after every step of C and before V's refresh,
and `P_per_D_given` = 1 once at the start. Such inputs are never connected; those the rule finds no pair for, and all
of them with the setting off or a component that provides no directional derivatives, stay at their start values
(0: nnfmu's vehicle then keeps its fitted elements exactly). A derivative that is not finite, or a call that
fails, at the start stops the run naming the element and port; later the last finite value is kept (the vehicle
also clamps negative values to 0).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from nnfmu.cosim.direct import RealBlock
from nnfmu.cosim.slave import FmuSlave
from nnfmu.errors import NnfmuError

PER, GIVEN = "_per_", "_given"


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
    """dP/dY for `element`'s input `name` = `P_per_Y`: `component`'s output `unknown` (feeding P, times `scale`) along
    the seed `seeds` on its inputs `knowns` (those Y feeds, each its connection's scale); no knowns: 0."""

    element: str
    name: str
    component: str
    unknown: int
    knowns: tuple[int, ...]
    seeds: tuple[float, ...]
    scale: float


def port_derivative_inputs(slaves: Mapping[str, FmuSlave], links: Sequence[Link]) -> dict[str, list[_Derivative]]:
    """Per element, its port derivative inputs found by the naming rule: `P_per_Y` where input P is fed by a
    component's output and Y is an output of the element (fed to that component's inputs, or to none of them: then
    the component's output does not depend on Y, and the value is 0)."""
    found: dict[str, list[_Derivative]] = {}
    for name, slave in slaves.items():
        inputs = derivative_inputs(slave.names("input"))
        outputs = set(slave.names("output"))
        for force in (link for link in links if link.target == name):
            for gain in sorted(g for g in inputs if g.startswith(f"{force.input}{PER}") and not g.endswith(GIVEN)):
                motion = gain.removeprefix(f"{force.input}{PER}")
                if motion not in outputs:
                    continue
                fed = [
                    link for link in links if (link.source, link.output, link.target) == (name, motion, force.source)
                ]
                component = slaves[force.source]
                (unknown,) = component.value_references([force.output])
                knowns = tuple(component.value_references([link.input for link in fed]))
                seeds = tuple(link.a * link.s for link in fed)
                derivative = _Derivative(name, gain, force.source, unknown, knowns, seeds, force.a * force.s)
                found.setdefault(name, []).append(derivative)
    return found


def derivative_inputs(inputs: Sequence[str]) -> set[str]:
    """The inputs among an element's `inputs` that the port-derivative rule may set: `X_per_Y` with its flag
    `X_per_Y_given`, and the flag."""
    names = set(inputs)
    return {n for g in names if PER in g and f"{g}{GIVEN}" in names for n in (g, f"{g}{GIVEN}")}


def exempt_inputs(slaves: Mapping[str, FmuSlave]) -> set[tuple[str, str]]:
    """(element, input) of every input the port-derivative rule may set: never connected, never refused as free."""
    return {(name, n) for name, slave in slaves.items() for n in derivative_inputs(slave.names("input"))}


def provides(slave: FmuSlave) -> bool:
    """The FMU declares directional derivatives (FMI 2 `providesDirectionalDerivative`, FMI 3 `...Derivatives`)."""
    return slave.provides_directional_derivatives


class PortDerivatives:
    """The port derivative inputs a run sets: `start` once after initialisation, `update` after each pass."""

    def __init__(self, slaves: Mapping[str, FmuSlave], links: Sequence[Link]) -> None:
        found = port_derivative_inputs(slaves, links)
        self.slaves = slaves
        kept = {name: [d for d in items if provides(slaves[d.component])] for name, items in found.items()}
        self.derivatives = {name: items for name, items in kept.items() if items}
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
        """Each `..._given` flag = 1 and the first values; PortDerivativeError for a value not to be had."""
        for name, items in self.derivatives.items():
            self.slaves[name].set_real([f"{d.name}{GIVEN}" for d in items], [1.0] * len(items))
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
        """The component's derivative along the seeds times the connections' scale; NaN where the call fails."""
        if not d.knowns:
            return 0.0
        try:  # fmpy's FMI 2 and FMI 3 calls take (unknowns, knowns, seed) alike
            value = self.slaves[d.component].fmu.getDirectionalDerivative([d.unknown], list(d.knowns), list(d.seeds))[0]
        except Exception:  # noqa: BLE001 (an FMI error status: fmpy raises its own exception class)
            return float("nan")
        return float(np.float64(value) * d.scale)
