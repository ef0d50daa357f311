"""`nnfmu rig`: a simulated lab record, self-made (lab, random, sine) or with a drive derived from a vehicle result."""

from __future__ import annotations

from pathlib import Path

from nnfmu.data.rigs import RIG_BANDS, DriveDesign, RigOptions, write_rig, write_vehicle_damper_dyno, write_vehicle_rig
from nnfmu.errors import SettingsError
from nnfmu.kinds import kind_of_rig

__all__ = ["RigOptions", "write_rig_record"]


def write_rig_record(
    kind: str,
    out: Path,
    options: RigOptions,
    drive_from: Path | None = None,
    elements: tuple[str, ...] | list[str] = (),
    margin: float = 1.2,
    band: str | None = None,
    fit_sensors: bool = True,
) -> tuple[Path, Path]:
    """Write the record of the `kind` rig to `out` and its truth file beside it; return (data, truth) paths.

    With excitation 'vehicle' (`drive_from` a vehicle result), the drive follows the result's `elements` (bushing
    deflections or damper strokes) with `margin` over their excursions, within the rig controller's pass `band`
    'LOW:HIGH' [Hz] (default per rig); `fit_sensors` sizes the bushing rig's transducers for the test. Options that
    do not go together raise SettingsError saying which."""
    if drive_from is not None and options.excitation != "vehicle":
        raise SettingsError(f"--drive-from sets the excitation to 'vehicle'; it cannot be {options.excitation!r} too")
    if options.excitation != "vehicle":
        return write_rig(kind, out, options)
    if kind not in RIG_BANDS:
        raise SettingsError(f"unknown rig kind {kind!r}; valid kinds: {', '.join(RIG_BANDS)}")
    if drive_from is None:
        raise SettingsError("excitation 'vehicle' needs --drive-from RESULT (a vehicle result file)")
    if not elements:
        raise SettingsError(f"--drive-from needs --element NAME (e.g. {kind_of_rig(kind).example})")
    write, sizes_sensors = _VEHICLE_RIGS[kind]
    if not sizes_sensors and not fit_sensors:
        raise SettingsError(
            "--default-sensors is for the bushing rig; the damper dyno always records with its own transducers"
        )
    try:
        low, high = (float(v) for v in band.split(":")) if band is not None else RIG_BANDS[kind]
    except ValueError:
        raise SettingsError(f"--band must be LOW:HIGH in Hz, e.g. 0.5:40; got {band!r}") from None
    design = DriveDesign(margin=margin, band=(low, high), fit_sensors=fit_sensors)
    return write(drive_from, list(elements), out, options, design)


# Per rig (a component kind's `rig`, `nnfmu.kinds`): its writer of a vehicle-derived record, and whether it sizes its
# transducers for the test (the bushing rig) or always records with its own (the damper dyno).
_VEHICLE_RIGS = {"damper": (write_vehicle_damper_dyno, False), "bushing": (write_vehicle_rig, True)}
