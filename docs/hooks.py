"""MkDocs hooks (mkdocs.yml `hooks:`): the pages made from the code and the benchmark files at build time, and the
navigation, so no command's help and no benchmark number is copied by hand.

- `cli.md`: `--help` of every `nnfmu` command, rendered from the commands themselves.
- `results.md`: every file in `bench/results/` (JSON, JSON lines), tables generated from its numbers.
- the navigation: the pages in `NAV` order, then any other page in `docs/` (pages other authors add appear without
  editing this list).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"
GENERATED = {"cli.md": "Command reference", "results.md": "Benchmark results"}
NAV: tuple[tuple[str, str], ...] = (
    ("Home", "index.md"),
    ("Getting started", "getting-started.md"),
    ("Commands", "commands.md"),
    ("Rig data", "rig-data.md"),
    ("File formats", "file-formats.md"),
    ("Networks", "networks.md"),
    ("Building FMUs", "building-fmus.md"),
    ("FMU semantics", "fmu.md"),
    ("FMU platforms", "platforms.md"),
    ("Vehicle and road test", "vehicle.md"),
    ("Semi-active closed loop", "skyhook.md"),
    ("System FMU", "system-fmu.md"),
    ("Campaigns", "campaigns.md"),
    ("Closing the loop", "loop.md"),
    ("Drive-file iteration", "iterate.md"),
    ("Component reports", "characterise.md"),
    ("Real data", "real-data.md"),
    ("Command reference", "cli.md"),
    ("Benchmark results", "results.md"),
    ("Architecture", "architecture.md"),
    ("Source layout", "layout.md"),
)


def on_config(config: Any) -> Any:
    """Navigation: `NAV` first, then every other Markdown page found in docs/ (by file name)."""
    docs = Path(config["docs_dir"])
    listed = {path for _, path in NAV}
    present = {p.relative_to(docs).as_posix() for p in docs.rglob("*.md")} | set(GENERATED)
    nav: list[Any] = [{title: path} for title, path in NAV if path in present]
    nav += [{_title(docs / path, path): path} for path in sorted(present - listed)]
    config["nav"] = nav
    return config


def _title(path: Path, name: str) -> str:
    """A page's first `# heading`, else its file name."""
    if path.is_file():
        for line in path.read_text(encoding="utf-8").splitlines():
            if line.startswith("# "):
                return line[2:].strip()
    return Path(name).stem.replace("-", " ").capitalize()


def on_files(files: Files, config: Any) -> Files:
    files.append(File.generated(config, "cli.md", content=cli_page()))
    files.append(File.generated(config, "results.md", content=results_page()))
    return files


# --- command reference -------------------------------------------------------------------------------------------


def cli_page() -> str:
    """Every command's `--help`, as `nnfmu <command> --help` prints it at 100 columns."""
    from typer.main import get_command
    from typer.testing import CliRunner

    from nnfmu.cli import app

    lines = [
        "# Command reference",
        "",
        "Generated at build time from the commands themselves (`nnfmu <command> --help`). Units are given in "
        "brackets, SI throughout.",
        "",
    ]
    for path in _command_paths(get_command(app)):
        result = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": "100"}, prog_name="nnfmu")
        if result.exit_code != 0:
            raise RuntimeError(f"nnfmu {' '.join(path)} --help failed: {result.output}")
        lines += [f"## nnfmu {' '.join(path)}".rstrip(), "", "```text", result.output.rstrip(), "```", ""]
    return "\n".join(lines)


def _command_paths(group: Any, path: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    found = [path]
    for name in sorted(getattr(group, "commands", {})):
        found += _command_paths(group.commands[name], (*path, name))
    return found


# --- benchmark results -------------------------------------------------------------------------------------------


def results_page() -> str:
    """One section per file in bench/results/: the networks benchmark as a table per variant, every other file's
    numbers as tables of their scalar values by key."""
    lines = [
        "# Benchmark results",
        "",
        "Generated at build time from `bench/results/` (the JSON the `bench/` scripts write); nothing here is "
        "typed by hand. Times were taken on the machines and loads the files record and are not comparable "
        "across files. Rerun a benchmark (`python bench/<name>.py`) to update its section.",
        "",
    ]
    networks = sorted(RESULTS.glob("networks-*.json"))
    if networks:
        lines += ["## Networks (`bench/networks.py`)", ""]
        for path in networks:
            lines += _networks_table(path)
    for path in sorted(RESULTS.iterdir()):
        if path in networks or path.suffix not in (".json", ".jsonl"):
            continue
        lines += [f"## `{path.name}`", ""]
        records = _records(path)
        for i, record in enumerate(records):
            if len(records) > 1:
                lines += [f"### record {i + 1} of {len(records)}", ""]
            lines += _scalar_table(record)
    return "\n".join(lines)


def _records(path: Path) -> list[Any]:
    """Every JSON value in the file, one after another (a `.json` file may hold several runs, as JSON lines do)."""
    text, decoder, records, at = path.read_text(encoding="utf-8"), json.JSONDecoder(), [], 0
    while True:
        while at < len(text) and text[at].isspace():
            at += 1
        if at == len(text):
            return records
        value, at = decoder.raw_decode(text, at)
        records.append(value)


def _number(value: Any) -> str:
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _per_cent(value: Any) -> str:
    return f"{100 * value:.2f} %" if isinstance(value, (int, float)) else "—"


def _networks_table(path: Path) -> list[str]:
    data = json.loads(path.read_text(encoding="utf-8"))
    lines = [
        f"### {data.get('variant', path.stem)} networks (`{path.name}`)",
        "",
        "| preset | network | held-out NRMSE vs true output | vs measured | target | largest \\|weight\\| | pass |",
        "|---|---|---|---|---|---|---|",
    ]
    for preset, row in data.get("presets", {}).items():
        lines.append(
            f"| {preset} | {row.get('network', '—')} | {_per_cent(row.get('heldout_nrmse_vs_true'))} | "
            f"{_per_cent(row.get('heldout_nrmse_vs_measured'))} | {_per_cent(row.get('target_nrmse'))} | "
            f"{_number(row.get('max_abs_weight'))} | {_number(row.get('pass'))} |"
        )
    return [*lines, ""]


def _scalar_table(record: Any) -> list[str]:
    """The scalar leaves of a JSON value as `key path | value` rows (lists of scalars joined)."""
    rows = list(_leaves(record, ""))
    if not rows:
        return ["(no scalar values)", ""]
    lines = ["| key | value |", "|---|---|"]
    lines += [f"| `{key or '(value)'}` | {value} |" for key, value in rows]
    return [*lines, ""]


def _leaves(value: Any, key: str):
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _leaves(v, f"{key}.{k}" if key else str(k))
    elif isinstance(value, list) and value and all(not isinstance(v, (dict, list)) for v in value):
        yield key, _cell(", ".join(_number(v) for v in value))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _leaves(v, f"{key}[{i}]")
    else:
        yield key, _cell(_number(value))


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")
