"""A campaign file (TOML) read into events, variants, coupling settings and metrics, every input resolved and hashed.

```toml
name = "damper valvings"                       # optional; default: the file's stem
[coupling]                                     # nnfmu.cosim.CosimSettings fields, by name
step = 1e-3
engine = "python"                              # or "compiled": each variant as a cached system FMU (docs/campaigns.md)
[metrics]
channels = ["damper_force", "body_acceleration"]   # default: every output channel
basquin_slope = 5.0                            # S-N exponent m of the pseudo-damage
slopes = { displacement = 3.0 }                # per quantity or channel, as `nnfmu validate --slope-for`
reference = "linear"                           # the variant damage ratios are taken against (default: the first)
[drive]                                        # defaults for every generated event (DriveSettings fields)
duration = 10.0
[[events]]                                     # a generated drive: DriveSettings fields, `class` for road_class
name = "C-20"
class = "C"
speed = 20.0
seed = 0
repeats = 3                                    # seeds seed, seed+1, seed+2 -> events C-20#0, C-20#1, C-20#2
potholes = [{ time = 4.0, depth = 0.05 }]      # Pothole fields; kerbs = [{ time = 6.0, height = 0.1 }]
[[events]]                                     # or a drive file (CSV, MDF4, RPC III)
name = "belgian-block"
drive = "drives/belgian-block.csv"
[[variants]]
name = "linear"
system = "systems/SystemStructure.ssd"         # .ssd, its folder, or .ssp
fmus = { damper = "fmus/firm.fmu" }            # element -> replacement FMU
parameters = { damper = { filter_cutoff = 0.0 } }   # element -> parameter values
```

Paths are relative to the campaign file and must lead, links followed, to regular files inside its folder (an FMU
is native code): `read_campaign(..., allow_outside=True)` (`nnfmu batch --allow-outside`) lifts the folder rule. A
campaign has at most MAX_CASES cases (events x variants), checked before any is made. Every unknown key is an error
naming the file, the entry and the key; the coupling and drive settings are checked by constructing `CosimSettings`
and `DriveSettings` here, so a bad value fails before any case runs. FMU bytes are read and hashed now (they travel
with the tasks); drive files are hashed now and read when their cases are sent (each at most MAX_FILE_BYTES).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from nnfmu.cosim import (
    CosimSettings,
    SspError,
    check_compiled,
)
from nnfmu.validate.damage import MAX_SLOPE
from nnfmu.vehicle import DriveError, DriveSettings, KerbStrike, Pothole
from nnfmu.workflows.campaign.errors import CampaignError
from nnfmu.workflows.campaign.hashing import bytes_sha256, file_bytes, file_sha256
from nnfmu.workflows.system import VirtualSystem

TOP_KEYS = ("name", "description", "coupling", "metrics", "drive", "events", "variants")
METRIC_KEYS = ("channels", "basquin_slope", "slopes", "reference")
VARIANT_KEYS = ("name", "system", "fmus", "parameters")
EVENT_ONLY_KEYS = ("name", "drive", "repeats", "potholes", "kerbs", "class")
EVENT_KINDS = {"potholes": Pothole, "kerbs": KerbStrike}
OFF_WHEN_ZERO = ("highpass", "lowpass")  # as on the command line: 0 switches the rig filter off
MAX_CAMPAIGN_BYTES = 16 * 1024**2  # the campaign file itself
MAX_CASES = 100_000  # events x variants of one campaign: each case is a co-simulation (a 10 s drive ~20 ms and up)
ENGINES = ("python", "compiled")  # `nnfmu cosim --engine`: the master's loop in Python, or the system FMU from C
DEFAULT_ENGINE = "python"  # faster for a campaign's typical run (docs/campaigns.md, Engines)


@dataclass(frozen=True)
class FileRef:
    """A file a case needs, known by content: `sha256` of its bytes and its `name` (for messages and its suffix)."""

    sha256: str
    name: str

    def identity(self) -> dict[str, str]:
        """The content and the suffix (which tells the format); the name and folder do not change the result."""
        return {"sha256": self.sha256, "suffix": Path(self.name).suffix.lower()}


@dataclass(frozen=True)
class EventSpec:
    """One drive: a file (`drive`) or generator settings (`generator`: DriveSettings fields as JSON values, the
    events as `potholes` and `kerbs` lists of field tables)."""

    name: str
    drive: FileRef | None = None
    generator: Mapping[str, Any] | None = None

    def identity(self) -> dict[str, Any]:
        """What the event's cases depend on (its hash input): the name and the drive's content or settings."""
        source = {"file": self.drive.identity()} if self.drive else {"generator": dict(self.generator)}
        return {"name": self.name, **source}


@dataclass(frozen=True)
class ElementPlan:
    """One element of a variant's system: its FMU by content, its connectors (name, kind) and parameter values."""

    name: str
    fmu: FileRef
    connectors: tuple[tuple[str, str], ...]
    parameters: Mapping[str, float]


@dataclass(frozen=True)
class VariantSpec:
    """A system to co-simulate: the base system with its FMU swaps and parameter values applied."""

    name: str
    system_name: str
    elements: tuple[ElementPlan, ...]
    connections: tuple[tuple[str, str, str, str], ...]
    start_time: float
    stop_time: float | None

    def identity(self) -> dict[str, Any]:
        """What the variant's cases depend on: the name, every element's FMU hash, connectors, parameters, wiring."""
        return {
            "name": self.name,
            "system": self.system_name,
            "start_time": self.start_time,
            "stop_time": self.stop_time,
            "connections": [list(c) for c in self.connections],
            "elements": [
                {
                    "name": e.name,
                    "fmu": e.fmu.identity(),
                    "parameters": dict(e.parameters),
                    "connectors": [list(c) for c in e.connectors],
                }
                for e in self.elements
            ],
        }


@dataclass(frozen=True)
class MetricSpec:
    """Channels to score (empty: every output), the Basquin slope m (per channel or quantity in `slopes`) and the
    reference variant of the damage ratios."""

    channels: tuple[str, ...]
    basquin_slope: float
    slopes: Mapping[str, float]
    reference: str

    def identity(self) -> dict[str, Any]:
        """What a case's rows depend on (the reference is applied when the table is assembled, so it is left out)."""
        return {"channels": list(self.channels), "basquin_slope": self.basquin_slope, "slopes": dict(self.slopes)}


@dataclass(frozen=True)
class Campaign:
    """A read campaign: events x variants, the coupling settings (CosimSettings keywords), the metrics, and the
    bytes or paths of every file a case needs, by SHA-256 (`blobs`)."""

    path: Path
    name: str
    description: str
    sha256: str
    events: tuple[EventSpec, ...]
    variants: tuple[VariantSpec, ...]
    coupling: Mapping[str, Any]
    metrics: MetricSpec
    blobs: Mapping[str, bytes | Path] = field(repr=False)
    engine: str = DEFAULT_ENGINE  # [coupling] engine: how each case's co-simulation runs (ENGINES)

    def resolved_coupling(self) -> dict[str, Any]:
        """Every CosimSettings field with its value for this campaign (the defaults filled in)."""
        return dataclasses.asdict(CosimSettings(**self.coupling))


def _table(value: Any, where: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise CampaignError(f"{where} must be a table, got {value!r}")
    return value


def _unknown(table: Mapping[str, Any], allowed: tuple[str, ...] | set[str], where: str) -> None:
    extra = [k for k in table if k not in allowed]
    if extra:
        raise CampaignError(f"{where}: unknown key {extra[0]!r} (allowed: {', '.join(sorted(allowed))})")


def _name(table: Mapping[str, Any], where: str) -> str:
    name = table.get("name")
    if not isinstance(name, str) or not name.strip() or any(c in name for c in "\n\r\t"):
        raise CampaignError(f"{where}: 'name' must be a non-empty one-line string, got {name!r}")
    return name.strip()


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise CampaignError(f"{where}: {value!r} is not a finite number")
    return float(value)


def _existing(base: Path, value: Any, where: str, allow_outside: bool, folder: bool = False) -> Path:
    """The resolved path of `value` (relative to `base`): an existing regular file (or, if `folder`, a folder too),
    inside `base` unless `allow_outside`."""
    if not isinstance(value, str) or not value:
        raise CampaignError(f"{where}: give a file path as a string, got {value!r}")
    path = (base / value).resolve()
    if not path.exists():
        raise CampaignError(f"{where}: {path} does not exist")
    if not allow_outside and base.resolve() != path and base.resolve() not in path.parents:
        raise CampaignError(
            f"{where}: {value!r} leads to {path}, outside the campaign's folder {base.resolve()}; pass "
            f"--allow-outside to use files from elsewhere (an FMU is native code), or put it inside the folder"
        )
    if not (path.is_file() or folder and path.is_dir()):
        raise CampaignError(f"{where}: {path} is not a regular file (a device, FIFO or socket is never read)")
    return path


def _coupling(table: Mapping[str, Any], where: str) -> tuple[dict[str, Any], str]:
    """The [coupling] table as CosimSettings keywords, checked by building CosimSettings from them (unknown fields
    named), and its `engine` (checked against the settings: the compiled engine steps one-pass schemes only)."""
    names = {f.name for f in dataclasses.fields(CosimSettings)}
    _unknown(table, names | {"engine"}, where)
    fields = {k: v for k, v in table.items() if k != "engine"}
    engine = table.get("engine", DEFAULT_ENGINE)
    if engine not in ENGINES:
        raise CampaignError(f"{where}: engine {engine!r} is not one of {', '.join(ENGINES)}")
    try:
        settings = CosimSettings(**fields)
        if engine == "compiled":
            check_compiled(settings)
    except (TypeError, ValueError) as error:
        raise CampaignError(f"{where}: {error}") from None
    return fields, engine


def _metrics(table: Mapping[str, Any], variants: list[str], where: str) -> MetricSpec:
    _unknown(table, METRIC_KEYS, where)
    channels = table.get("channels", [])
    if not isinstance(channels, list) or not all(isinstance(c, str) and c for c in channels):
        raise CampaignError(f"{where}: 'channels' must be a list of channel names, got {channels!r}")
    if len(set(channels)) != len(channels):
        raise CampaignError(f"{where}: 'channels' names a channel twice: {channels!r}")
    slope = _number(table.get("basquin_slope", 5.0), f"{where}: basquin_slope")
    slopes = {
        k: _number(v, f"{where}: slopes.{k}") for k, v in _table(table.get("slopes", {}), f"{where}: slopes").items()
    }
    for key, value in {"basquin_slope": slope, **slopes}.items():
        if not 0 < value <= MAX_SLOPE:
            raise CampaignError(f"{where}: Basquin slope {key} = {value!r} must lie in (0, {MAX_SLOPE:g}]")
    reference = table.get("reference", variants[0] if variants else None)
    if reference not in variants:
        raise CampaignError(
            f"{where}: reference variant {reference!r} is not one of the variants ({', '.join(variants)})"
        )
    return MetricSpec(tuple(channels), slope, slopes, reference)


def _drive_fields(table: Mapping[str, Any], where: str) -> dict[str, Any]:
    """DriveSettings keywords from a table of generator keys (`class` for road_class, 0 = filter off)."""
    names = {f.name for f in dataclasses.fields(DriveSettings)} - {"events"}
    fields = {}
    for key, value in table.items():
        key = "road_class" if key == "class" else key
        if key not in names:
            raise CampaignError(
                f"{where}: unknown drive setting {key!r} (DriveSettings fields: {', '.join(sorted(names))}, or class)"
            )
        if key == "band":
            value = tuple(value) if isinstance(value, list) else value
        if key in OFF_WHEN_ZERO and value == 0:
            value = None
        fields[key] = value
    return fields


def _road_events(table: Mapping[str, Any], where: str) -> dict[str, list[dict[str, Any]]]:
    """The potholes and kerbs of an event, each a table of the event class's fields (checked by building it)."""
    found: dict[str, list[dict[str, Any]]] = {}
    for key, kind in EVENT_KINDS.items():
        items = table.get(key, [])
        if not isinstance(items, list):
            raise CampaignError(f"{where}: {key!r} must be a list of tables, got {items!r}")
        allowed = {f.name for f in dataclasses.fields(kind)}
        for i, item in enumerate(items):
            item_where = f"{where}: {key}[{i}]"
            _unknown(_table(item, item_where), allowed, item_where)
            try:
                kind(**item)
            except TypeError as error:
                raise CampaignError(f"{item_where}: {error}") from None
        found[key] = [dict(item) for item in items]
    return found


def road_events(generator: Mapping[str, Any]) -> tuple[Pothole | KerbStrike, ...]:
    """The Pothole and KerbStrike objects of a generator entry."""
    return tuple(kind(**item) for key, kind in EVENT_KINDS.items() for item in generator.get(key, []))


def drive_settings(generator: Mapping[str, Any]) -> DriveSettings:
    """DriveSettings of a generator entry (its fields, the events built from their tables)."""
    fields = {k: (tuple(v) if k == "band" else v) for k, v in generator.items() if k not in EVENT_KINDS}
    return DriveSettings(**fields, events=road_events(generator))


def _generator(fields: dict[str, Any], events: dict[str, list[dict[str, Any]]], where: str) -> dict[str, Any]:
    """Every DriveSettings field of a generated event as JSON values, checked by DriveSettings.check()."""
    try:
        settings = DriveSettings(**fields, events=road_events(events))
        settings.check()
    except (TypeError, DriveError) as error:
        raise CampaignError(f"{where}: {error}") from None
    resolved = dataclasses.asdict(settings)
    del resolved["events"]
    resolved["band"] = list(resolved["band"])
    return resolved | events


def _events(
    entries: Any,
    defaults: Mapping[str, Any],
    base: Path,
    blobs: dict[str, bytes | Path],
    where: str,
    allow_outside: bool,
    variants: int,
) -> list[EventSpec]:
    """The events of the [[events]] entries, at most MAX_CASES // `variants` of them (checked before each is made)."""
    if not isinstance(entries, list) or not entries:
        raise CampaignError(f"{where}: give at least one [[events]] entry")
    shared = _drive_fields(defaults, f"{where}: [drive]")
    events: list[EventSpec] = []
    for i, entry in enumerate(entries):
        entry_where = f"{where}: events[{i}]"
        entry = _table(entry, entry_where)
        name = _name(entry, entry_where)
        entry_where = f"{where}: event {name!r}"
        repeats = entry.get("repeats", 1)
        if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
            raise CampaignError(f"{entry_where}: repeats must be a whole number >= 1, got {repeats!r}")
        if (len(events) + (1 if "drive" in entry else repeats)) * variants > MAX_CASES:
            raise CampaignError(
                f"{entry_where}: repeats = {repeats} makes more than {MAX_CASES} cases ({len(events)} event(s) "
                f"before it, x {variants} variant(s)), the most a campaign may have; split the campaign"
            )
        if "drive" in entry:
            others = [k for k in entry if k not in ("name", "drive")]
            if others:
                raise CampaignError(
                    f"{entry_where}: a drive file takes no generator key or repeats "
                    f"(found {others[0]!r}; a file gives the same drive every time)"
                )
            path = _existing(base, entry["drive"], f"{entry_where}: drive", allow_outside)
            sha = file_sha256(path)
            blobs[sha] = path
            events.append(EventSpec(name, drive=FileRef(sha, path.name)))
            continue
        fields = shared | _drive_fields(
            {k: v for k, v in entry.items() if k not in EVENT_ONLY_KEYS or k == "class"}, entry_where
        )
        road = _road_events(entry, entry_where)
        seed = fields.get("seed", 0)
        seeded = repeats > 1 and isinstance(seed, int) and not isinstance(seed, bool)
        labels = [f"{name}#{r}" if repeats > 1 else name for r in range(repeats)]
        # repeats differ in the seed only: the settings are checked with the first and the last seed, not per repeat
        first = _generator(fields, road, f"{where}: event {labels[0]!r}")
        if seeded:
            _generator(fields | {"seed": seed + repeats - 1}, road, f"{where}: event {labels[-1]!r}")
        for r, label in enumerate(labels):
            events.append(EventSpec(label, generator=first | {"seed": seed + r} if seeded else first))
    twice = sorted(n for n, count in Counter(e.name for e in events).items() if count > 1)
    if twice:
        raise CampaignError(f"{where}: event name(s) used twice: {', '.join(map(repr, twice))}")
    return events


def _fmu_ref(path: Path, blobs: dict[str, bytes | Path]) -> FileRef:
    data = file_bytes(path)
    sha = bytes_sha256(data)
    blobs[sha] = data
    return FileRef(sha, path.name)


def _variant(
    entry: Mapping[str, Any], base: Path, blobs: dict[str, bytes | Path], where: str, allow_outside: bool
) -> VariantSpec:
    """The base system with the entry's FMU swaps and parameters, checked against the FMUs, FMU bytes read."""
    _unknown(entry, VARIANT_KEYS, where)
    name = _name(entry, where)
    where = f"{where.rsplit(':', 1)[0]}: variant {name!r}"
    system_path = _existing(base, entry.get("system"), f"{where}: system", allow_outside, folder=True)
    swaps = {
        k: _existing(base, v, f"{where}: fmus.{k}", allow_outside)
        for k, v in _table(entry.get("fmus", {}), f"{where}: fmus").items()
    }
    parameters = {
        k: {
            p: _number(v, f"{where}: parameters.{k}.{p}") for p, v in _table(values, f"{where}: parameters.{k}").items()
        }
        for k, values in _table(entry.get("parameters", {}), f"{where}: parameters").items()
    }
    try:
        with VirtualSystem.open(system_path, allow_outside) as system:
            unknown = [e for e in list(swaps) + list(parameters) if e not in system.elements]
            if unknown:
                raise CampaignError(
                    f"{where}: system {system_path} has no element {unknown[0]!r} (has: {', '.join(system.elements)})"
                )
            changed = system.swap(swaps).with_parameters(parameters).structure
            plans = tuple(
                ElementPlan(
                    e.name,
                    _fmu_ref(Path(e.source), blobs),
                    tuple((c.name, c.kind) for c in e.connectors),
                    dict(e.parameters),
                )
                for e in changed.elements
            )
            wiring = tuple(
                (c.start_element, c.start_connector, c.end_element, c.end_connector) for c in changed.connections
            )
            return VariantSpec(name, changed.name, plans, wiring, changed.start_time, changed.stop_time)
    except SspError as error:
        raise CampaignError(f"{where}: {error}") from None


def read_campaign(path: str | Path, allow_outside: bool = False) -> Campaign:
    """Read and check a campaign file; CampaignError names the file, the entry and the key of the first problem.
    Files (drives, systems, FMUs, a system's FMUs) must lie inside the campaign's folder unless `allow_outside`."""
    path = Path(path).resolve()
    try:
        text = file_bytes(path, MAX_CAMPAIGN_BYTES)
        raw = tomllib.loads(text.decode("utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise CampaignError(f"{path}: cannot read the campaign: {error}") from None
    except RecursionError:  # tomllib recurses once per nested array or table
        raise CampaignError(f"{path}: cannot read the campaign: its arrays or tables are nested too deeply") from None
    where = str(path)
    _unknown(raw, TOP_KEYS, where)
    base = path.parent
    blobs: dict[str, bytes | Path] = {}
    entries = raw.get("variants")
    if not isinstance(entries, list) or not entries:
        raise CampaignError(f"{where}: give at least one [[variants]] entry")
    if len(entries) > MAX_CASES:
        raise CampaignError(f"{where}: {len(entries)} variants, more than the {MAX_CASES} cases a campaign may have")
    variants = [
        _variant(_table(e, f"{where}: variants[{i}]"), base, blobs, f"{where}: variants[{i}]", allow_outside)
        for i, e in enumerate(entries)
    ]
    names = [v.name for v in variants]
    twice = sorted(n for n, count in Counter(names).items() if count > 1)
    if twice:
        raise CampaignError(f"{where}: variant name(s) used twice: {', '.join(map(repr, twice))}")
    defaults = _table(raw.get("drive", {}), f"{where}: [drive]")
    events = _events(raw.get("events"), defaults, base, blobs, where, allow_outside, len(variants))
    description = raw.get("description", "")
    name = raw.get("name", path.stem)
    if not isinstance(name, str) or not isinstance(description, str):
        raise CampaignError(f"{where}: 'name' and 'description' must be strings")
    coupling, engine = _coupling(_table(raw.get("coupling", {}), f"{where}: [coupling]"), f"{where}: [coupling]")
    return Campaign(
        path=path,
        name=name,
        description=description,
        sha256=bytes_sha256(text),
        events=tuple(events),
        variants=tuple(variants),
        coupling=coupling,
        metrics=_metrics(_table(raw.get("metrics", {}), f"{where}: [metrics]"), names, f"{where}: [metrics]"),
        blobs=blobs,
        engine=engine,
    )
