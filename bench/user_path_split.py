"""Split the user's-path error (bench/user_path.py) into its causes, from the files a run of it left in its folder.

- where in time: each channel's squared error in the pothole's window (0.4·duration - 0.5 s to + 1.5 s) against the
  rest, as shares of the whole run's;
- the network alone: the damper network run open loop (its step graph, onnxruntime) on the reference car's damper
  velocity against the reference's damper force (the dyno's law), its NRMSE over the run, on the samples inside and
  outside its training envelope, and in and out of the pothole's window; the largest force error and where;
- offsets: the network's force at rest (zero velocity, settled) and the mean force error; the displacement error's
  mean before, in and after the pothole's window (a drift is a mean force error integrated by the suspension);
- the coupling's share: the dyno's law as an FMU in the network's place (law/result.csv).

Usage: python bench/user_path_split.py RUN_DIR  -> JSON on the last line (RUN_DIR: bench/user_path.py's folder)
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import onnx

from nnfmu.component import Component
from nnfmu.data import load_measurement
from nnfmu.export.step_runner import run_step_graph
from nnfmu.validate.metrics import nrmse, rms

sys.path.insert(0, str(Path(__file__).resolve().parent))
from user_path import CHANNELS, reference  # noqa: E402


def _channel(result, channel: str) -> np.ndarray:
    return result[next(n for n in result.channels if n.endswith(channel))]


def _share(err: np.ndarray, mask: np.ndarray) -> float:
    return float(np.sum(err[mask] ** 2) / np.sum(err**2))


def main() -> None:
    folder = Path(sys.argv[1]).resolve()
    truth = reference(folder, folder / "road.csv")
    result = load_measurement(folder / "result.csv")
    law = load_measurement(folder / "law" / "result.csv")
    t = result.time
    duration = float(t[-1] - t[0] + result.sample_period)
    pothole = 0.4 * round(duration)
    window = (t >= pothole - 0.5) & (t <= pothole + 1.5)
    split: dict[str, dict] = {"time": {}, "coupling": {}, "displacement_mean_error_m": {}}
    for channel in CHANNELS:
        want = np.interp(t, truth["time"], truth[channel])
        err = _channel(result, channel) - want
        split["time"][channel] = {
            "nrmse": nrmse(_channel(result, channel), want),
            "share_of_squared_error_in_window": _share(err, window),
            "nrmse_without_window": nrmse(_channel(result, channel)[~window], want[~window]),
            "nrmse_in_window": nrmse(_channel(result, channel)[window], want[window]),
        }
        split["coupling"][channel] = nrmse(_channel(law, channel), want)
        if channel == "damper_displacement":
            for name, mask in (("before", t < pothole - 0.5), ("window", window), ("after", t > pothole + 1.5)):
                split["displacement_mean_error_m"][name] = float(np.mean(err[mask]))
            split["displacement_rms_m"] = rms(want)

    # the network open loop on the reference car's damper motion
    model = onnx.load(folder / "damper.onnx")
    port = Component.from_onnx(model).inputs[0]
    v = np.interp(t, truth["time"], truth["damper_velocity"])
    f_true = np.interp(t, truth["time"], truth["damper_force"])
    f_net = run_step_graph(model, {port.name: v})[Component.from_onnx(model).outputs[0].name]
    err = f_net - f_true
    inside = (v >= port.min) & (v <= port.max)
    rest = run_step_graph(model, {port.name: np.zeros(2000)})
    worst = int(np.argmax(np.abs(err)))
    split["network_open_loop"] = {
        "envelope_m/s": [port.min, port.max],
        "velocity_range_m/s": [float(v.min()), float(v.max())],
        "share_outside_envelope": float(np.mean(~inside)),
        "nrmse": nrmse(f_net, f_true),
        "nrmse_inside_envelope": nrmse(f_net[inside], f_true[inside]),
        "share_of_squared_error_outside_envelope": _share(err, ~inside),
        "nrmse_without_window": nrmse(f_net[~window], f_true[~window]),
        "nrmse_in_window": nrmse(f_net[window], f_true[window]),
        "mean_error_N": float(np.mean(err)),
        "mean_error_without_window_N": float(np.mean(err[~window])),
        "force_at_rest_N": float(rest[Component.from_onnx(model).outputs[0].name][-1]),
        "largest_error_N": float(err[worst]),
        "largest_error_at_s": float(t[worst]),
        "largest_error_velocity_m/s": float(v[worst]),
        "truth_force_there_N": float(f_true[worst]),
        "force_rms_N": rms(f_true),
    }
    print(json.dumps(split, indent=1))
    print(json.dumps(split))


if __name__ == "__main__":
    main()
