"""The folder replacement both loops share (`nnfmu loop`, `nnfmu loop vehicle`): only files the marker lists as
nnfmu's, unchanged, are replaced; the user's files, folders and links stay, and a clash is refused before anything
moves."""

from __future__ import annotations

from pathlib import Path

import pytest

from nnfmu.out_paths import MARKER, OutputPathError, check_output_dir, replace_output_dir


def _result(tmp_path: Path, name: str, files: dict[str, str]) -> Path:
    """A finished result in a staging folder."""
    staging = tmp_path / name
    for rel, text in files.items():
        (staging / rel).parent.mkdir(parents=True, exist_ok=True)
        (staging / rel).write_text(text)
    return staging


def test_a_rerun_replaces_only_the_listed_files_and_keeps_the_rest(tmp_path: Path) -> None:
    out = tmp_path / "out"
    replace_output_dir(_result(tmp_path, "s1", {"report.json": "1", "system/car.fmu": "fmu 1"}), out, "vehicle-loop")
    (out / "notes.txt").write_text("mine")
    (out / "system" / "extra.csv").write_text("mine too")
    (out / "empty").mkdir()
    (out / "link").symlink_to(tmp_path / "s1")
    assert check_output_dir(out, "vehicle-loop", replaces=True) == out
    replace_output_dir(_result(tmp_path, "s2", {"report.json": "2", "system/car.fmu": "fmu 2"}), out, "vehicle-loop")
    assert (out / "report.json").read_text() == "2" and (out / "system" / "car.fmu").read_text() == "fmu 2"
    assert (out / "notes.txt").read_text() == "mine" and (out / "system" / "extra.csv").read_text() == "mine too"
    assert (out / "empty").is_dir() and (out / "link").is_symlink()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_a_changed_listed_file_a_clash_and_a_copied_marker_are_refused(tmp_path: Path) -> None:
    out = tmp_path / "out"
    replace_output_dir(_result(tmp_path, "s1", {"report.json": "1"}), out, "loop")
    (out / "report.json").write_text("edited")
    with pytest.raises(OutputPathError, match="report.json was changed"):
        check_output_dir(out, "loop", replaces=True)
    (out / "report.json").write_text("1")
    (out / "plot.png").write_text("mine")
    with pytest.raises(OutputPathError, match="plot.png: is not nnfmu's"):
        replace_output_dir(_result(tmp_path, "s2", {"report.json": "2", "plot.png": "ours"}), out, "loop")
    assert (out / "plot.png").read_text() == "mine" and (out / "report.json").read_text() == "1"
    other = tmp_path / "other"
    other.mkdir()
    (other / MARKER).write_text("loop\n")
    (other / "thesis.tex").write_text("mine")
    with pytest.raises(OutputPathError, match="does not list the files nnfmu wrote"):
        check_output_dir(other, "loop", replaces=True)
