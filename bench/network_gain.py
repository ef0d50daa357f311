"""Where a trained network's input-error gain comes from, against what its record itself shows (issue 31).

For a trained damper network (ONNX step graph) and its dyno record: the network's largest gain (sum_i |dy/dx_i| in
scaled units) and where it is, its gradient there per input, the record's own gain (`data_gain`, the warning's
bound), the force's binned slope against the scaled velocity (its largest, the bleed and friction near zero) and the
truth's bleed slope in the same units. The record is loaded as `nnfmu train` loads it (moving mass estimated and
taken out). Prints one JSON document.

Usage: python bench/network_gain.py MODEL.onnx DYNO.csv [--preset damper-hysteresis]
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import torch

from nnfmu.export import read_step_graph
from nnfmu.models.metrics import data_gain, gain_limit, network_warning
from nnfmu.models.presets import get_preset
from nnfmu.models.train import prepare_data
from nnfmu.physics.damper import DamperParams
from nnfmu.workflows.train import TrainRequest, _load

SLOPE_BIN = 0.005  # scaled velocity per bin of the force's binned slope
SLOPE_ROWS = 20  # rows per bin at least


def binned_slope(v: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Largest slope of the mean scaled force between neighbouring bins of scaled velocity, and where (scaled v)."""
    key = np.floor(v / SLOPE_BIN).astype(np.int64)
    bins, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    keep = counts >= SLOPE_ROWS
    centre = (np.bincount(inverse, weights=v) / counts)[keep]
    mean = (np.bincount(inverse, weights=y) / counts)[keep]
    slope = np.diff(mean) / np.diff(centre)
    slope[np.diff(bins[keep]) != 1] = 0.0
    at = int(np.argmax(slope))
    return float(slope[at]), float(centre[at])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model")
    parser.add_argument("record")
    parser.add_argument("--preset", default="damper-hysteresis")
    args = parser.parse_args()
    model, _ = read_step_graph(args.model)
    spec = model.spec
    measurement, mass, _ = _load(args.record, [*spec.channels, spec.output], spec.output, TrainRequest(args.preset))
    data = prepare_data(measurement, spec, get_preset(args.preset).settings.splits)
    network = model.network.double()
    rows = data.x.clone().requires_grad_(True)
    (gradient,) = torch.autograd.grad(network(rows)[:, 0].sum(), rows)
    gains = gradient.abs().sum(dim=1).numpy()
    at = int(np.argmax(gains))
    own = data_gain(data.x.numpy(), data.y.numpy())
    velocity = spec.feature_names.index("velocity[k]")
    slope, where = binned_slope(data.x.numpy()[:, velocity], data.y.numpy())
    v_half = float((data.feature_scaler.hi[velocity] - data.feature_scaler.lo[velocity]) / 2)
    f_half = float((data.target_scaler.hi - data.target_scaler.lo) / 2)
    bleed = DamperParams().rebound.c_low
    print(
        json.dumps(
            {
                "model": args.model,
                "record": args.record,
                "moving_mass_kg": mass,
                "hidden": network.hidden.out_features,
                "largest_abs_weight": max(float(p.detach().abs().max()) for p in network.parameters()),
                "network_gain": float(gains[at]),
                "network_gain_at_velocity_m_s": float(measurement["velocity"][at]),
                "network_gradient_there": dict(zip(spec.feature_names, gradient[at].tolist())),
                "network_gain_percentiles_50_90_99": np.percentile(gains, [50, 90, 99]).tolist(),
                "record_gain": own,
                "limit": gain_limit(own),
                "ratio": float(gains[at]) / own if own else None,
                "warning": network_warning(network, data.x, data.y),
                "force_binned_slope_scaled": slope,
                "force_binned_slope_at_velocity_m_s": where * v_half,
                "truth_bleed_slope_scaled": bleed * v_half / f_half,
                "velocity_half_range_m_s": v_half,
                "force_half_range_n": f_half,
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
