"""Run a step graph sample by sample in onnxruntime from its initial state: the reference every later stage checks
against.

Needs only onnx, onnxruntime and `nnfmu.component` (no torch), so FMU and validation stages can use it too.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
from onnx import helper

from nnfmu.component import Component
from nnfmu.export.errors import ExportError


def _load(source: str | os.PathLike[str] | onnx.ModelProto) -> onnx.ModelProto:
    return source if isinstance(source, onnx.ModelProto) else onnx.load(Path(source))


def _shapes(value_infos: list[onnx.ValueInfoProto]) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Concrete shape (symbolic dimensions as 1) and numpy dtype of each tensor."""
    shapes = {}
    for vi in value_infos:
        tensor_type = vi.type.tensor_type
        dims = tuple(d.dim_value if d.HasField("dim_value") and d.dim_value > 0 else 1 for d in tensor_type.shape.dim)
        shapes[vi.name] = (dims, np.dtype(helper.tensor_dtype_to_np_dtype(tensor_type.elem_type)))
    return shapes


def run_step_graph(
    source: str | os.PathLike[str] | onnx.ModelProto, channels: dict[str, np.ndarray]
) -> dict[str, np.ndarray]:
    """Evaluate the graph once per sample over `channels` (input port name -> (n,)), starting from the initial state.

    Returns output port name -> (n,). The state output of sample k is fed back as the state input of sample k+1.
    A component that interpolates its inputs gets each sample's interval start from the sample before (sample 0:
    its own inputs), as its FMU does when the inputs are set at every sample's time.
    """
    model = _load(source)
    component = Component.from_onnx(model)
    initializers = {i.name for i in model.graph.initializer}
    in_shapes = _shapes([vi for vi in model.graph.input if vi.name not in initializers])
    arrays: dict[str, np.ndarray] = {}
    for port in component.inputs:
        if port.name not in channels:
            raise ExportError(f"input channel {port.name!r} missing (have {sorted(channels)})")
        arrays[port.name] = np.asarray(channels[port.name], dtype=np.float64).ravel()
    lengths = {len(a) for a in arrays.values()}
    if len(lengths) > 1:
        raise ExportError(f"input channels have different lengths: { {k: len(a) for k, a in arrays.items()} }")
    n = lengths.pop() if lengths else 0

    session = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    output_names = [o.name for o in session.get_outputs()]
    state = {
        s.input: np.asarray(s.initial, dtype=in_shapes[s.input][1]).reshape(in_shapes[s.input][0])
        for s in component.states
    }
    feeds = {name: np.zeros(shape, dtype) for name, (shape, dtype) in in_shapes.items() if name not in state}
    results = {port.name: np.empty(n) for port in component.outputs}
    for k in range(n):
        for port in component.inputs:
            feeds[port.tensor].flat[port.index] = arrays[port.name][k]
            if component.interpolates_inputs:
                feeds[component.interval_starts[port.tensor]].flat[port.index] = arrays[port.name][max(k - 1, 0)]
        values = dict(zip(output_names, session.run(output_names, {**feeds, **state})))
        for port in component.outputs:
            results[port.name][k] = values[port.tensor].flat[port.index]
        state = {s.input: values[s.output] for s in component.states}
    return results
