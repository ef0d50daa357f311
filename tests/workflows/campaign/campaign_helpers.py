"""Campaign files for the tests: generated 1-2 s class C drives on the quarter car, variants by damper FMU swap."""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from pathlib import Path

import pyarrow.parquet as pq

DAMPERS = {"linear": 2400.0, "firm": 3600.0, "unstable": 1.0e7}  # [N.s/m]; 1e7 N.s/m on a 1 ms explicit exchange
CHANNELS = ("damper_force", "body_acceleration", "damper_displacement")
METRIC_COLUMNS = ("rms", "peak", "valley", "damage", "damage_ratio")


def campaign_text(
    quarter_car: dict[str, Path],
    events: int = 3,
    variants: tuple[str, ...] = ("linear", "firm"),
    duration: float = 1.0,
    extra_events: str = "",
    coupling: str = "step = 1e-3",
) -> str:
    """A campaign of `events` generated class C drives (seeds 0..events-1 via repeats) x damper `variants`."""
    lines = [
        'name = "test campaign"',
        f"[coupling]\n{coupling}",
        f'[metrics]\nchannels = {list(CHANNELS)!r}\nslopes = {{ displacement = 3.0 }}\nreference = "{variants[0]}"',
        f"[drive]\nduration = {duration}",
        f'[[events]]\nname = "C-20"\nclass = "C"\nspeed = 20.0\nrepeats = {events}',
        extra_events,
    ]
    for name in variants:
        lines.append(
            f'[[variants]]\nname = "{name}"\nsystem = "{quarter_car["system"]}"\n'
            f'fmus = {{ damper = "{quarter_car[name]}" }}'
        )
    return "\n".join(lines) + "\n"


def write_campaign(folder: Path, text: str) -> Path:
    """`folder/campaign.toml` with `text`; the test fixtures' files it names by absolute path (the quarter car's
    folder, built once per session) are linked into `folder` and named relative to it, as a campaign must keep its
    files inside its folder unless allowed otherwise."""
    folder.mkdir(parents=True, exist_ok=True)
    temp = Path(tempfile.gettempdir()).resolve()
    named = {Path(p).parent for p in re.findall(r'"(/[^"]+)"', text) if temp in Path(p).resolve().parents}
    for i, source in enumerate(sorted(named)):
        local = folder / f"inputs-{i}"
        local.mkdir(exist_ok=True)
        for f in source.iterdir():
            if f.is_file() and not (local / f.name).exists():
                try:
                    os.link(f, local / f.name)
                except OSError:
                    shutil.copyfile(f, local / f.name)
        text = text.replace(f'"{source}/', f'"{local.name}/')
    path = folder / "campaign.toml"
    path.write_text(text, encoding="utf-8")
    return path


def read_rows(out: Path) -> list[dict]:
    """The results table's rows sorted by event, variant and channel (wall times and case keys left in)."""
    rows = pq.read_table(out / "results.parquet").to_pylist()
    return sorted(rows, key=lambda r: (r["event"], r["variant"], r["channel"]))


def metrics_of(rows: list[dict]) -> list[tuple]:
    """What must not depend on where a case ran: names, unit, status and every score (NaN as None)."""
    return [
        (
            r["event"],
            r["variant"],
            r["channel"],
            r["unit"],
            r["status"],
            *(None if r[c] != r[c] else r[c] for c in METRIC_COLUMNS),
        )
        for r in rows
    ]  # NaN as None: comparable
