"""`nnfmu data check`: load a lab file as nnfmu reads it for training, in SI units with the loader's notes."""

from __future__ import annotations

from pathlib import Path

from nnfmu.data import Measurement, load_measurement, parse_channel_map

__all__ = ["check_data_file", "parse_channel_map"]


def check_data_file(path: Path, required: list[str], channel_map: dict[str, str]) -> Measurement:
    """The measurement in `path` with `required` channels present and file channels renamed by `channel_map`; a bad
    file raises DataError naming the file, line or channel."""
    return load_measurement(path, required=required, channel_map=channel_map)
