"""Drive signals for a virtual four-post road test simulator: ISO 8608 road synthesis and events (the file
formats are `nnfmu.data.drive_files`)."""

from nnfmu.vehicle.drive.errors import DriveError
from nnfmu.vehicle.drive.events import KerbStrike, Pothole
from nnfmu.vehicle.drive.generator import CHANNELS, generate_drive
from nnfmu.vehicle.drive.road import CLASS_LEVELS, displacement_psd, track_coherence
from nnfmu.vehicle.drive.settings import DriveSettings

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
