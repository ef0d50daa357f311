"""Rig data: load CSV/MDF measurements into SI units, check them, derive missing rates, save them."""

from .checks import check_measurement
from .derive import derive_rates
from .errors import DataError
from .load import load_measurement
from .measurement import Measurement
from .save import save_measurement
from .units import to_si

__all__ = [
    "DataError",
    "Measurement",
    "check_measurement",
    "derive_rates",
    "load_measurement",
    "save_measurement",
    "to_si",
]
