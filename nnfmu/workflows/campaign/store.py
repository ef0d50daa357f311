"""Result parts (one Parquet file per finished case, written atomically) and the campaign table assembled from them.

`DIR/parts/<case key>.parquet` holds a case's rows: one per channel, or for a failed case one per chosen channel
(one row with an empty channel when every output was asked for) with NaN scores and the error. The table
`DIR/results.parquet` is the parts of the campaign's current cases put together, with `damage_ratio`: the case's
damage over the reference variant's damage on the same event and channel.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from nnfmu.atomic import atomic_path
from nnfmu.workflows.campaign.cases import Case
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


def write_part(out: Path, outcome: CaseOutcome, channels: Sequence[str]) -> Path:
    """Write a case's part via a temporary file and a rename (a part exists whole or not at all)."""
    path = part_path(out, outcome.key)
    with atomic_path(path) as tmp:
        pq.write_table(outcome_table(outcome, channels), tmp)
    return path


def finished(out: Path, cases: Iterable[Case], retry_failed: bool) -> set[str]:
    """Keys of the cases whose part exists (the failed ones left out when they are to be run again)."""
    done = set()
    for case in cases:
        path = part_path(out, case.key)
        if not path.is_file():
            continue
        if retry_failed and FAILED in pq.read_table(path, columns=["status"]).column("status").to_pylist():
            continue
        done.add(case.key)
    return done


def assemble(out: Path, cases: Sequence[Case], reference: str) -> pa.Table:
    """The parts of `cases` (in case order) with damage ratios against `reference`; every case must have a part."""
    parts = [pq.read_table(part_path(out, case.key), schema=PART_SCHEMA) for case in cases]
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
