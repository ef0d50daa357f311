"""Drive files for a virtual four-post road test simulator: ISO 8608 road synthesis, events, CSV/MDF4/RPC III."""

from .errors import DriveError
from .events import KerbStrike, Pothole
from .generator import CHANNELS, generate_drive
from .io import read_drive, write_drive
from .road import CLASS_LEVELS, displacement_psd, track_coherence
from .settings import DriveSettings

__all__ = [
    "CHANNELS",
    "CLASS_LEVELS",
    "DriveError",
    "DriveSettings",
    "KerbStrike",
    "Pothole",
    "displacement_psd",
    "generate_drive",
    "read_drive",
    "track_coherence",
    "write_drive",
]
