"""Rig data: load CSV/MDF/MTS 793 measurements into SI units, check them, derive missing rates, save them."""

from .channel_map import parse_channel_map
from .checks import check_measurement
from .derive import derive_rates
from .drive_files import read_drive, write_drive
from .errors import DataError
from .load import load_measurement
from .measurement import Measurement
from .save import save_measurement
from .units import to_si

__all__ = [
    "read_drive",
    "write_drive",
    "DataError",
    "Measurement",
    "check_measurement",
    "derive_rates",
    "load_measurement",
    "parse_channel_map",
    "save_measurement",
    "to_si",
]
