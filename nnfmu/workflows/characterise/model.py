"""The model under test as an FMU at its default parameters: an FMU as given, or one built from an ONNX step graph
into a temporary folder; its kind read from its `Component`; each test point replayed through it."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nnfmu.atomic import scratch_dir
from nnfmu.component import Component, Port
from nnfmu.cosim import FmuSlave, replay_fmu
from nnfmu.data.measurement import Measurement
from nnfmu.fmu import BuildOptions, build_fmu, host_binaries_only, load_onnx, read_fmu_graph
from nnfmu.input_files import not_regular
from nnfmu.workflows.characterise.kind import BushingPorts, CharacteriseError, DamperPorts, component_kind
from nnfmu.workflows.characterise.signals import SineTest, TestMotion, sine_motion

DEFAULT_PERIOD = 1e-3  # [s] the test clock of a graph without a sample period (another tool's, stateless)


@dataclass(frozen=True)
class ModelUnderTest:
    """The FMU the tests run, the file given, its component description, kind and sample period [s]."""

    fmu: Path
    source: Path
    component: Component
    kind: DamperPorts | BushingPorts
    period: float


def _component_of_fmu(fmu: Path) -> Component:
    """The component the FMU carries in its step graph; for an FMU without one, its variables' names and units."""
    import onnx

    found = read_fmu_graph(fmu)
    if found is not None:
        return Component.from_onnx(onnx.load_from_string(found[0]))
    with FmuSlave(fmu, instance_name=fmu.stem) as slave:
        ports = {c: [Port(n, slave.unit(n)) for n in slave.names(c)] for c in ("input", "output")}
        return Component(fmu.stem, ports["input"], ports["output"], sample_period=slave.sample_period)


@contextmanager
def model_under_test(path: str | Path) -> Iterator[ModelUnderTest]:
    """The model of `path` (`.onnx` or `.fmu`) ready to test; an ONNX is built into a native FMU (host binary)
    inside a temporary folder removed afterwards. CharacteriseError naming the file for anything else."""
    path = Path(path)
    if not path.is_file():
        raise CharacteriseError(f"{path}: {not_regular(Path(path)) or 'no such file'}")
    suffix = path.suffix.lower()
    if suffix not in (".onnx", ".fmu"):
        raise CharacteriseError(f"{path}: give an ONNX step graph (.onnx) or an FMU (.fmu)")
    with scratch_dir("nnfmu-characterise-") as folder:
        try:
            component = Component.from_onnx(load_onnx(path)) if suffix == ".onnx" else _component_of_fmu(path)
        except ValueError as err:  # a malformed or too new component description
            raise CharacteriseError(f"{path}: cannot read the component description: {err}") from err
        kind = component_kind(component, str(path))  # refused before an ONNX is built
        fmu = path
        if suffix == ".onnx":
            with host_binaries_only():
                fmu = build_fmu(path, BuildOptions(out=Path(folder) / f"{path.stem}.fmu"))
        yield ModelUnderTest(fmu, path, component, kind, component.sample_period or DEFAULT_PERIOD)


@dataclass(frozen=True)
class TestRun:
    """One test point run on the model: the test, its motion and the model's force over the whole test."""

    test: SineTest
    motion: TestMotion
    force: np.ndarray

    def cycle(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Time [s], position, rate and force of the measured cycle."""
        m = self.motion.measured
        return self.motion.time[m], self.motion.position[m], self.motion.rate[m], self.force[m]


def run_test(model: ModelUnderTest, test: SineTest, inputs: Mapping[str, tuple[str, str]], output: str) -> TestRun:
    """Replay `test` through the model's FMU: `inputs` maps each FMU input to (signal, unit), the signal one of
    `position`, `rate`, `zero`, `command` or a number held; the model's `output` is returned."""
    motion = sine_motion(test, model.period)
    signals = {"position": motion.position, "rate": motion.rate, "zero": np.zeros_like(motion.time)}
    if test.command is not None:
        signals["command"] = np.full_like(motion.time, test.command)
    channels = {}
    for name, (signal, _unit) in inputs.items():
        channels[name] = signals[signal] if signal in signals else np.full_like(motion.time, float(signal))
    record = Measurement(
        time=motion.time,
        channels=channels,
        units={name: unit for name, (_signal, unit) in inputs.items()},
        source=f"{test.frequency:g} Hz test of {model.source}",
    )
    result = replay_fmu(model.fmu, record)
    if output not in result:
        raise CharacteriseError(
            f"{model.source}: the FMU has no output {output!r} (outputs: {', '.join(result.names)})"
        )
    return TestRun(test, motion, np.asarray(result[output], dtype=float))
