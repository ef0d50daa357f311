"""Validation: compare a result with a reference by NRMSE, R², peaks, mean shift, RMS, PSD and rainflow
pseudo-damage, and write PNG plots, `summary.json` and an HTML report."""

from nnfmu.validate.compare import (
    ChannelComparison,
    ValidationError,
    ValidationSettings,
    common_channels,
    compare,
    quantity_of,
)
from nnfmu.validate.damage import pseudo_damage, pseudo_damage_ratio, rainflow_cycles
from nnfmu.validate.files import ValidationReport, validate_files
from nnfmu.validate.metrics import (
    DEFINITIONS,
    mean_shift,
    nrmse,
    peak_error,
    peak_ratio,
    r2,
    rms,
    rms_ratio,
    valley_ratio,
)
from nnfmu.validate.report import write_report
from nnfmu.validate.spectra import Spectrum, welch_psd
from nnfmu.validate.summary import ChannelMetrics, channel_metrics
from nnfmu.validate.verdict import DEFAULT_TARGET_NRMSE, Target, verdict

__all__ = [
    "DEFAULT_TARGET_NRMSE",
    "DEFINITIONS",
    "ChannelComparison",
    "ChannelMetrics",
    "Spectrum",
    "ValidationError",
    "ValidationReport",
    "ValidationSettings",
    "Target",
    "channel_metrics",
    "common_channels",
    "compare",
    "mean_shift",
    "nrmse",
    "peak_error",
    "peak_ratio",
    "pseudo_damage",
    "pseudo_damage_ratio",
    "quantity_of",
    "r2",
    "rainflow_cycles",
    "rms",
    "rms_ratio",
    "valley_ratio",
    "validate_files",
    "verdict",
    "welch_psd",
    "write_report",
]
