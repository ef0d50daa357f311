"""Validate a result file against a reference file: load both, compare channels, write the report (`nnfmu validate`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from nnfmu.data import load_measurement
from nnfmu.out_paths import check_output_dir, mark_output_dir
from nnfmu.validate.compare import ChannelComparison, ValidationSettings, common_channels, compare
from nnfmu.validate.report import SUMMARY_FILE, report_verdict, write_report
from nnfmu.validate.verdict import Target


@dataclass(frozen=True)
class ValidationReport:
    """What `validate_files` produced: the comparisons, the report's `index.html` and `summary.json`, and its verdict
    line."""

    comparisons: list[ChannelComparison]
    index_html: Path
    summary_json: Path
    verdict: str = ""


def settings_context(settings: ValidationSettings) -> dict[str, str]:
    """The settings as report context lines."""
    window = (
        f"{settings.window[0]:g} to {settings.window[1]:g} s"
        if settings.window is not None
        else f"{settings.window_length:g} s around the reference's global peak"
    )
    slopes = ", ".join(f"{k}: {v:g}" for k, v in settings.slopes.items())
    return {
        "Basquin slope m": f"{settings.basquin_slope:g}" + (f" ({slopes})" if slopes else ""),
        "PSD": f"Welch, Hann, {settings.psd_resolution:g} Hz resolution, 0 to {settings.fmax:g} Hz",
        "time-history window": window,
    }


def validate_files(
    result_path: str | os.PathLike[str],
    reference_path: str | os.PathLike[str],
    channels: Sequence[str] | None,
    out_dir: str | os.PathLike[str],
    settings: ValidationSettings | None = None,
    target: Target = Target(),
) -> ValidationReport:
    """Compare `channels` (default: every channel both files hold) of a result CSV/MDF4 with a reference and write
    the report into `out_dir`, its verdict against `target`. Bad files, missing channels and unit mismatches raise
    `DataError` naming them; an `out_dir` that is a file, holds an input or files nnfmu did not write as a report
    raises OutputPathError."""
    settings = settings or ValidationSettings()
    out_dir = check_output_dir(out_dir, "validate", [result_path, reference_path])
    result = load_measurement(result_path)
    reference = load_measurement(reference_path)
    chosen = list(channels) if channels else common_channels(result, reference)
    comparisons = compare(result, reference, chosen, settings)
    context = {
        "result": str(result_path),
        "reference": str(reference_path),
        "created": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC"),
        **settings_context(settings),
    }
    title = f"Validation of {Path(result_path).name} against {Path(reference_path).name}"
    index = write_report(comparisons, out_dir, title, context, target)
    mark_output_dir(out_dir, "validate")
    return ValidationReport(
        comparisons=comparisons,
        index_html=index,
        summary_json=index.parent / SUMMARY_FILE,
        verdict=report_verdict(comparisons, target),
    )
