"""The native FMU in a second, independent master (libcosim via libcosimpy) gives the same results as in fmpy.

libcosimpy 0.0.6 loads FMI 1.0/2.0 FMUs only (its FMI Library build rejects, then crashes on, FMI 3.0), so the FMI 2
FMU is run here; the FMI 3 FMU is checked in fmpy (test_native_fmu.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from native_fmu_helpers import SAMPLE_PERIOD, Reference, delay_step_graph

libcosim_execution = pytest.importorskip("libcosimpy.CosimExecution")
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level  # noqa: E402
from libcosimpy.CosimManipulator import CosimManipulator  # noqa: E402
from libcosimpy.CosimObserver import CosimObserver  # noqa: E402
from libcosimpy.CosimSlave import CosimLocalSlave  # noqa: E402

STEP = 2.5 * SAMPLE_PERIOD  # not a multiple of the sample period: samples and holds mixed
STEP_NS = 2_500_000


def run_in_libcosim(fmu_path, inputs: np.ndarray) -> tuple[np.ndarray, list[bool]]:
    """Outputs after each step (row n after step n, n >= 1), `inputs[n]` overriding the inputs before step n."""
    log_output_level(CosimLogLevel.ERROR)
    execution = libcosim_execution.CosimExecution.from_step_size(STEP_NS)
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=str(fmu_path), instance_name="damper"))
    refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    manipulator = CosimManipulator.create_override()
    observer = CosimObserver.create_last_value()
    execution.add_manipulator(manipulator)
    execution.add_observer(observer)
    input_refs = [refs["velocity"], refs["displacement"]]
    for ref, value in zip(input_refs, inputs[0]):
        execution.real_initial_value(index, ref, float(value))
    rows, flags = [], []
    for n in range(1, len(inputs)):
        manipulator.slave_real_values(index, input_refs, [float(x) for x in inputs[n]])
        assert execution.step(1), f"libcosim step {n} failed"
        rows.append(observer.last_real_values(index, [refs["force"], refs["torque"]]))
        flags.append(bool(observer.last_boolean_values(index, [refs["extrapolating"]])[0]))
    return np.array(rows), flags


@pytest.mark.slow
def test_libcosim_matches_fmpy_and_onnxruntime(filtered_fmus, open_fmu):
    rng = np.random.default_rng(17)
    inputs = np.column_stack([rng.uniform(-1.2, 1.2, 2_000), rng.uniform(-0.1, 0.1, 2_000)])
    cosim_rows, cosim_flags = run_in_libcosim(filtered_fmus[2], inputs)
    fmpy_rows = open_fmu(filtered_fmus[2]).simulate(inputs, STEP)[1:]
    # Same binary, same calls; libcosim's step sizes are differences of its time points in doubles, fmpy's the one h,
    # so the elapsed time can differ in the last bit, and a communication point between samples (every other one
    # here) evaluates the graph at that fraction of the period: equal to rounding, 1e-10 of the peak at most.
    peak = np.max(np.abs(fmpy_rows), axis=0)
    assert np.all(np.max(np.abs(cosim_rows - fmpy_rows), axis=0) <= 1e-10 * peak)
    expected = Reference(delay_step_graph()).simulate(inputs, STEP, cutoff=100.0)[1:]
    np.testing.assert_allclose(cosim_rows, expected, rtol=1e-9, atol=1e-12)
    assert any(cosim_flags) and not all(cosim_flags)  # inputs beyond +-1 m/s raise the flag
