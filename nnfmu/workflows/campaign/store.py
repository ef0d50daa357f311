"""Result parts (one Parquet file per finished case, written atomically) and the campaign table assembled from them.

`DIR/parts/<case key>.parquet` holds a case's rows: one per channel, or for a failed case one per chosen channel
(one row with an empty channel when every output was asked for) with NaN scores and the error. The table
`DIR/results.parquet` is the parts of the campaign's current cases put together, with `damage_ratio`: the case's
damage over the reference variant's damage on the same event and channel.

A part carries its case key and the SHA-256 of its rows in the Parquet metadata; a resumed run takes a part as
finished only when it reads, names its case in the metadata and in every row and its rows hash to that checksum.
Any other part (truncated, corrupted, copied from another case) is reported and its case run again.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from nnfmu.atomic import atomic_path
from nnfmu.workflows.campaign.cases import Case
from nnfmu.workflows.campaign.errors import CampaignError
from nnfmu.workflows.campaign.execute import FAILED, OK, CaseOutcome

PARTS = "parts"
TABLE = "results.parquet"
PART_SCHEMA = pa.schema(
    [
        ("case", pa.string()),
        ("event", pa.string()),
        ("variant", pa.string()),
        ("channel", pa.string()),
        ("unit", pa.string()),
        ("rms", pa.float64()),
        ("peak", pa.float64()),
        ("valley", pa.float64()),
        ("damage", pa.float64()),
        ("basquin_slope", pa.float64()),
        ("wall_s", pa.float64()),
        ("status", pa.string()),
        ("error", pa.string()),
    ]
)
TABLE_SCHEMA = PART_SCHEMA.insert(PART_SCHEMA.get_field_index("basquin_slope"), pa.field("damage_ratio", pa.float64()))


def part_path(out: Path, key: str) -> Path:
    return out / PARTS / f"{key}.parquet"


def outcome_table(outcome: CaseOutcome, channels: Sequence[str]) -> pa.Table:
    """The rows of one case's part."""
    nan = math.nan
    if outcome.status == OK:
        rows = [
            dict(
                channel=r.channel,
                unit=r.unit,
                rms=r.rms,
                peak=r.peak,
                valley=r.valley,
                damage=r.damage,
                basquin_slope=r.basquin_slope,
            )
            for r in outcome.rows
        ]
    else:
        rows = [
            dict(channel=c, unit="", rms=nan, peak=nan, valley=nan, damage=nan, basquin_slope=nan)
            for c in channels or [""]
        ]
    common = dict(
        case=outcome.key,
        event=outcome.event,
        variant=outcome.variant,
        wall_s=outcome.wall_s,
        status=outcome.status,
        error=outcome.error,
    )
    return pa.Table.from_pylist([common | row for row in rows], schema=PART_SCHEMA)


CASE_KEY = b"nnfmu.case"  # Parquet metadata: the case key a part belongs to
CHECKSUM_KEY = b"nnfmu.sha256"  # Parquet metadata: SHA-256 of the part's rows


def rows_sha256(table: pa.Table) -> str:
    """SHA-256 of a part's rows as JSON (NaN spelled as such), independent of how Parquet stored them."""
    text = json.dumps(table.to_pylist(), sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def write_part(out: Path, outcome: CaseOutcome, channels: Sequence[str]) -> Path:
    """Write a case's part, with its case key and checksum, via a temporary file and a rename (a part exists whole
    or not at all)."""
    path = part_path(out, outcome.key)
    table = outcome_table(outcome, channels)
    table = table.replace_schema_metadata({CASE_KEY: outcome.key.encode(), CHECKSUM_KEY: rows_sha256(table).encode()})
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)
    return path


def read_part(out: Path, case: Case) -> pa.Table:
    """The verified part of `case`; CampaignError naming the file and what is wrong when it cannot be read, belongs
    to another case or its rows do not match its checksum."""
    path = part_path(out, case.key)
    try:
        if not path.is_file():
            raise CampaignError(f"{path}: no part file (or not a regular file)")
        stored = pq.read_table(path)
        table = stored.cast(PART_SCHEMA)
    except CampaignError:
        raise
    except Exception as error:  # pyarrow raises ArrowInvalid, OSError and others for a truncated or foreign file
        raise CampaignError(f"{path}: cannot read the part: {error}") from None
    meta = stored.schema.metadata or {}
    if meta.get(CASE_KEY) != case.key.encode():
        raise CampaignError(f"{path}: the part does not name case {case.key} in its metadata (another case's part?)")
    wrong = sorted({k for k in table.column("case").to_pylist() if k != case.key})
    if wrong or not table.num_rows:
        raise CampaignError(f"{path}: rows of case(s) {', '.join(wrong) or '(none)'} in the part of case {case.key}")
    if set(table.column("event").to_pylist()) != {case.event.name} or set(table.column("variant").to_pylist()) != {
        case.variant.name
    }:
        raise CampaignError(
            f"{path}: rows of another event or variant than {case.event.name!r} x {case.variant.name!r}"
        )
    if meta.get(CHECKSUM_KEY) != rows_sha256(table).encode():
        raise CampaignError(f"{path}: the part's rows do not match its checksum (changed after it was written)")
    return table


def finished(
    out: Path, cases: Iterable[Case], retry_failed: bool, report: Callable[[str], None] = lambda _: None
) -> set[str]:
    """Keys of the cases whose part exists and is verified (`read_part`; the failed ones left out when they are to
    be run again); a part that exists but fails verification is `report`ed and its case run again."""
    done = set()
    for case in cases:
        path = part_path(out, case.key)
        if not path.exists() and not path.is_symlink():
            continue
        try:
            table = read_part(out, case)
        except CampaignError as error:
            report(f"{error}; the case runs again")
            continue
        if retry_failed and FAILED in table.column("status").to_pylist():
            continue
        done.add(case.key)
    return done


def assemble(out: Path, cases: Sequence[Case], reference: str) -> pa.Table:
    """The parts of `cases` (in case order) with damage ratios against `reference`; every case must have a part."""
    parts = [read_part(out, case) for case in cases]
    table = pa.concat_tables(parts) if parts else PART_SCHEMA.empty_table()
    events, variants, channels = (table.column(c).to_pylist() for c in ("event", "variant", "channel"))
    damage = table.column("damage").to_numpy(zero_copy_only=False)
    status = table.column("status").to_pylist()
    base = {
        (e, c): d for e, v, c, d, s in zip(events, variants, channels, damage, status) if v == reference and s == OK
    }
    ratio = np.array(
        [
            d / base[(e, c)] if s == OK and base.get((e, c), 0.0) > 0 else math.nan
            for e, c, d, s in zip(events, channels, damage, status)
        ],
        dtype=float,
    )
    table = table.add_column(TABLE_SCHEMA.get_field_index("damage_ratio"), "damage_ratio", pa.array(ratio))
    return table.cast(TABLE_SCHEMA)


def write_table(out: Path, table: pa.Table) -> Path:
    path = out / TABLE
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)
    return path
