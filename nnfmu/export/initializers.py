"""Names of the initializers an nnfmu step graph stores its network and scalers under: written by the exporter,
read back by `read_step_graph`, so that renaming one side cannot break the other at run time."""

from __future__ import annotations

HIDDEN_LAYER = "hidden"  # the MLP's tanh layer
OUTPUT_LAYER = "out"  # the linear output layer (MLP and GRU)
FEATURE_MIN, FEATURE_GAIN = "feature_min", "feature_gain"  # min-max scaling of the features to [-1, 1]
TARGET_MIN, TARGET_GAIN = "target_min", "target_gain"  # and of the output


def layer_initializers(layer: str) -> tuple[str, str]:
    """(weight, bias) initializer names of a linear layer."""
    return f"{layer}_weight", f"{layer}_bias"


MLP_INITIALIZERS = (*layer_initializers(HIDDEN_LAYER), *layer_initializers(OUTPUT_LAYER))
SCALER_INITIALIZERS = (FEATURE_MIN, FEATURE_GAIN, TARGET_MIN, TARGET_GAIN)
