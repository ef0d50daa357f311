"""Every command's `--help` shows the units its help texts give (`[m/s]`, `[s]`, ...) and fits an 80-column terminal."""

from __future__ import annotations

import re
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from nnfmu.cli import app

BRACKETED = re.compile(r"\[[^\[\]]+\]")


def _commands(group: Any, path: tuple[str, ...] = ()) -> list[tuple[tuple[str, ...], Any]]:
    """Every command under `group` (typer's own click) with the words that call it."""
    found = [(path, group)]
    for name, command in getattr(group, "commands", {}).items():
        found += _commands(command, (*path, name))
    return found


COMMANDS = _commands(typer.main.get_command(app))


def _bracketed(command: Any) -> set[str]:
    """The bracketed texts (units, formats) of a command's own help and its parameters' help."""
    texts = [command.help or ""] + [getattr(p, "help", None) or "" for p in command.params]
    return {m for text in texts for m in BRACKETED.findall(text)}


def _flat(text: str) -> str:
    return " ".join(text.split())


def test_commands_are_found_and_carry_units() -> None:
    names = {" ".join(path) for path, _ in COMMANDS}
    assert {"demo", "build", "drive generate", "data check", "loop-vehicle"} <= names
    assert "[m/s]" in _bracketed(dict((" ".join(p), c) for p, c in COMMANDS)["drive generate"])


@pytest.mark.parametrize("columns", ["80", "200"])
@pytest.mark.parametrize("path", [p for p, _ in COMMANDS], ids=lambda p: " ".join(p) or "nnfmu")
def test_help_shows_every_bracketed_unit(path: tuple[str, ...], columns: str) -> None:
    command = dict(COMMANDS)[path]
    result = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": columns})
    assert result.exit_code == 0, result.output
    shown = _flat(result.output)
    missing = [text for text in sorted(_bracketed(command)) if _flat(text) not in shown]
    assert not missing, f"nnfmu {' '.join(path)} --help lost {missing}"
    if columns == "80":
        wide = [line for line in result.output.splitlines() if len(line) > 80]
        assert not wide, wide


def test_data_check_help_shows_the_file_format() -> None:
    result = CliRunner().invoke(app, ["data", "check", "--help"], env={"COLUMNS": "80"})
    assert "`name [unit]` headers, `time [s]` first" in _flat(result.output)
