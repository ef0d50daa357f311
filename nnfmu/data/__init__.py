"""Rig data: load CSV/MDF/MTS 793 measurements into SI units, check them, derive missing rates, save them."""

from nnfmu.data.channel_map import parse_channel_map
from nnfmu.data.checks import check_measurement
from nnfmu.data.derive import derive_rates
from nnfmu.data.drive_files import read_drive, write_drive
from nnfmu.data.errors import DataError
from nnfmu.data.load import load_measurement
from nnfmu.data.measurement import Measurement
from nnfmu.data.save import save_measurement
from nnfmu.data.units import to_si

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
