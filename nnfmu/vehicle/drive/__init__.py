"""Drive signals for a virtual four-post road test simulator: ISO 8608 road synthesis and events (the file
formats are `nnfmu.data.drive_files`)."""

from .errors import DriveError
from .events import KerbStrike, Pothole
from .generator import CHANNELS, generate_drive
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
    "track_coherence",
]
