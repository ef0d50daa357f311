"""`nnfmu drive generate|convert`: four-poster drive files from an ISO 8608 road with events, or between formats."""

from __future__ import annotations

from pathlib import Path

from nnfmu.data.drive_files import RpcDataType, read_drive, write_drive
from nnfmu.vehicle import DriveSettings, KerbStrike, Pothole, generate_drive

__all__ = ["DriveSettings", "KerbStrike", "Pothole", "convert_drive", "write_generated_drive"]


def write_generated_drive(settings: DriveSettings, out: Path, rpc_data_type: RpcDataType = "int16") -> Path:
    """Generate the drive `settings` describe and write it to `out` (format by suffix)."""
    return write_drive(generate_drive(settings), out, rpc_data_type=rpc_data_type)


def convert_drive(source: Path, target: Path, rpc_data_type: RpcDataType = "int16") -> Path:
    """Read a drive file and write it in the format of `target`'s suffix, channel names and units kept."""
    return write_drive(read_drive(source), target, rpc_data_type=rpc_data_type)
