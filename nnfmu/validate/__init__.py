"""Validation: compare a result with a reference by NRMSE, R², peaks, mean shift, RMS, PSD and rainflow
pseudo-damage, and write PNG plots, `summary.json` and an HTML report."""

from .compare import ChannelComparison, ValidationError, ValidationSettings, common_channels, compare, quantity_of
from .damage import pseudo_damage, pseudo_damage_ratio, rainflow_cycles
from .files import ValidationReport, validate_files
from .metrics import DEFINITIONS, mean_shift, nrmse, peak_error, peak_ratio, r2, rms, rms_ratio, valley_ratio
from .report import write_report
from .spectra import Spectrum, welch_psd
from .summary import ChannelMetrics, channel_metrics

__all__ = [
    "DEFINITIONS",
    "ChannelComparison",
    "ChannelMetrics",
    "Spectrum",
    "ValidationError",
    "ValidationReport",
    "ValidationSettings",
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
    "welch_psd",
    "write_report",
]
