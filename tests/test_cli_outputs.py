"""`--out` of every command: nnfmu never deletes or replaces what it did not write, and a bad output path is one
`error:` line naming it, with the inputs untouched."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.out_paths import MARKER

runner = CliRunner()


def invoke(*args: object):
    return runner.invoke(app, [str(a) for a in args])


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file below `folder` with its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A user's folder: a dyno record, a small model trained on it, and an unrelated file."""
    folder = tmp_path_factory.mktemp("mywork")
    made = invoke(
        "rig", "damper", "--out", folder / "dyno.csv", "--duration", "20", "--seed", "2", "--excitation", "random"
    )
    assert made.exit_code == 0, made.output
    (folder / "dyno.truth.json").unlink()
    trained = invoke(
        "train",
        folder / "dyno.csv",
        "--preset",
        "damper-spline",
        "--out",
        folder / "model.onnx",
        "--max-epochs",
        "5",
        "--restarts",
        "1",
        "--hidden",
        "3",
    )
    assert trained.exit_code == 0, trained.output
    (folder / "notes.txt").write_text("my unrelated notes\n")
    return folder


def refused(result, path: object) -> None:
    """One `error:` line naming `path`, exit status 2, no traceback."""
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    assert "error:" in result.output and str(path) in result.output, result.output


@pytest.mark.slow
def test_loop_refuses_a_folder_holding_its_inputs_and_deletes_nothing(work: Path) -> None:
    before = snapshot(work)
    result = invoke("loop", work / "dyno.csv", "--model", work / "model.onnx", "--out", work, "--max-effects", "0")
    refused(result, work)
    assert "input" in result.output
    assert snapshot(work) == before


def test_loop_refuses_the_current_folder(work: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(work)
    before = snapshot(work)
    result = invoke("loop", "dyno.csv", "--model", "model.onnx", "--out", ".", "--max-effects", "0")
    refused(result, "--out .")
    assert snapshot(work) == before
    assert not [p for p in work.parent.iterdir() if ".old-" in p.name or ".staging-" in p.name]


@pytest.mark.slow
def test_loop_refuses_a_foreign_folder_and_replaces_its_own_earlier_result(work: Path, tmp_path: Path) -> None:
    foreign = tmp_path / "someone"
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("do not lose me")
    result = invoke("loop", work / "dyno.csv", "--model", work / "model.onnx", "--out", foreign, "--max-effects", "0")
    refused(result, foreign)
    assert "not empty" in result.output and (foreign / "thesis.tex").read_text() == "do not lose me"
    ours = tmp_path / "loop"
    for _ in range(2):  # the second run replaces the first one's folder: nnfmu wrote it
        ok = invoke("loop", work / "dyno.csv", "--model", work / "model.onnx", "--out", ours, "--max-effects", "0")
        assert ok.exit_code == 0, ok.output
        assert (ours / "report.json").exists() and (ours / MARKER).read_text().splitlines()[0] == "loop"
    (ours / MARKER).write_text("validate\n")  # another command's result is not the loop's to replace
    other = invoke("loop", work / "dyno.csv", "--model", work / "model.onnx", "--out", ours, "--max-effects", "0")
    refused(other, ours)
    assert (ours / "report.json").exists()


def test_build_train_cosim_and_convert_refuse_to_overwrite_their_input(work: Path, tmp_path: Path) -> None:
    before = snapshot(work)
    refused(invoke("build", work / "model.onnx", "--out", work / "model.onnx"), work / "model.onnx")
    refused(
        invoke(
            "train", work / "dyno.csv", "--preset", "damper-spline", "--out", work / "dyno.csv", "--max-epochs", "1"
        ),
        work / "dyno.csv",
    )
    ssd = tmp_path / "SystemStructure.ssd"
    ssd.write_text("<not read: the output is checked first/>")
    drive = work / "dyno.csv"
    refused(invoke("cosim", ssd, "--drive", drive, "--out", drive), drive)
    refused(invoke("cosim", ssd, "--drive", drive, "--out", ssd), ssd)
    refused(invoke("drive", "convert", drive, drive), drive)
    os.link(work / "model.onnx", tmp_path / "hardlink.onnx")  # another name of the same file is the same input
    refused(invoke("build", work / "model.onnx", "--out", tmp_path / "hardlink.onnx"), tmp_path / "hardlink.onnx")
    assert snapshot(work) == before


def test_a_file_output_that_is_a_folder_empty_or_under_a_file_is_refused(work: Path, tmp_path: Path) -> None:
    folder = tmp_path / "existing"
    folder.mkdir()
    refused(invoke("build", work / "model.onnx", "--out", folder), folder)
    result = invoke("build", work / "model.onnx", "--out", "")
    assert result.exit_code == 2 and "error: --out is empty" in result.output, result.output
    under = tmp_path / "plain.txt"
    under.write_text("a file")
    refused(invoke("build", work / "model.onnx", "--out", under / "x.fmu"), under)
    slash = f"{tmp_path / 'newdir'}/"
    refused(invoke("build", work / "model.onnx", "--out", slash), slash)
    refused(invoke("drive", "generate", "--out", slash, "--duration", "1"), slash)
    assert not (tmp_path / "newdir").exists()
    assert under.read_text() == "a file" and not any(folder.iterdir())


@pytest.mark.slow
def test_validate_refuses_an_existing_file_and_a_foreign_folder(work: Path, tmp_path: Path) -> None:
    target = tmp_path / "report.html"
    target.write_text("someone's page")
    refused(invoke("validate", work / "dyno.csv", work / "dyno.csv", "--out", target), target)
    assert target.read_text() == "someone's page"
    refused(invoke("validate", work / "dyno.csv", work / "dyno.csv", "--out", work), work)
    report = tmp_path / "report"
    for _ in range(2):
        ok = invoke("validate", work / "dyno.csv", work / "dyno.csv", "--out", report, "-c", "force")
        assert ok.exit_code == 0, ok.output
    assert (report / MARKER).read_text().strip() == "validate"


def _special_files(folder: Path, suffix: str) -> list[Path]:
    """A FIFO named `pipe<suffix>` (mkfifo needs no privilege) and, when running as root, a character device like
    /dev/null named `null<suffix>`: neither may be replaced by the regular file a command writes."""
    fifo = folder / f"pipe{suffix}"
    os.mkfifo(fifo)
    made = [fifo]
    if os.geteuid() == 0:
        device = folder / f"null{suffix}"
        os.mknod(device, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
        made.append(device)
    return made


def _still_special(path: Path) -> bool:
    mode = path.lstat().st_mode
    return stat.S_ISFIFO(mode) or stat.S_ISCHR(mode)


@pytest.mark.parametrize(
    "suffix, command",
    [
        (".fmu", lambda work, out: ("build", work / "model.onnx", "--out", out)),
        (".onnx", lambda work, out: ("train", work / "dyno.csv", "--preset", "damper-spline", "--out", out)),
        (".csv", lambda work, out: ("rig", "damper", "--out", out, "--duration", "1")),
        (".fmu", lambda work, out: ("vehicle", "build", "quarter-car", "--out", out)),
        (".fmu", lambda work, out: ("controller", "build", "skyhook", "--out", out)),
        (".csv", lambda work, out: ("cosim", work / "SystemStructure.ssd", "--drive", work / "dyno.csv", "--out", out)),
        (".csv", lambda work, out: ("drive", "generate", "--out", out, "--duration", "1")),
        (".csv", lambda work, out: ("drive", "convert", work / "dyno.csv", out)),
    ],
)
def test_a_fifo_or_device_as_the_output_file_is_refused_and_kept(work: Path, tmp_path: Path, suffix, command) -> None:
    (work / "SystemStructure.ssd").write_text("<not read: the output is checked first/>")
    for special in _special_files(tmp_path, suffix):
        result = invoke(*command(work, special))
        refused(result, special)
        assert "regular file" in result.output, result.output
        assert _still_special(special), f"{special} was replaced by {stat.filemode(special.lstat().st_mode)}"
    assert all(p.name.startswith(("pipe", "null")) for p in tmp_path.iterdir()), list(tmp_path.iterdir())


@pytest.mark.slow
def test_a_loop_rerun_keeps_the_users_files_in_its_folder_and_a_copied_marker_deletes_nothing(
    work: Path, tmp_path: Path
) -> None:
    def loop(out: Path):
        return invoke("loop", work / "dyno.csv", "--model", work / "model.onnx", "--out", out, "--max-effects", "0")

    ours = tmp_path / "loop"
    assert loop(ours).exit_code == 0
    (ours / "precious_notes.txt").write_text("my notes")
    (ours / "mine").mkdir()
    (ours / "mine" / "plot.png").write_bytes(b"not nnfmu's")
    again = loop(ours)
    assert again.exit_code == 0, again.output
    assert (ours / "precious_notes.txt").read_text() == "my notes" and (ours / "report.json").exists()
    assert (ours / "mine" / "plot.png").read_bytes() == b"not nnfmu's"
    (ours / "report.html").write_text("my edits of the report")  # nnfmu's file, changed since: the user's now
    refused(loop(ours), ours / "report.html")
    assert (ours / "report.html").read_text() == "my edits of the report"
    elsewhere = tmp_path / "thesis"
    elsewhere.mkdir()
    (elsewhere / "report.json").write_text("my own report")
    (elsewhere / "chapter.tex").write_text("do not lose me")
    (elsewhere / MARKER).write_bytes((ours / MARKER).read_bytes())  # a copied marker makes nothing deletable
    before = snapshot(elsewhere)
    refused(loop(elsewhere), elsewhere / "report.json")
    assert snapshot(elsewhere) == before
    (elsewhere / "report.json").unlink()
    assert loop(elsewhere).exit_code == 0
    assert (elsewhere / "chapter.tex").read_text() == "do not lose me" and (elsewhere / "report.json").exists()
    (ours / MARKER).write_text("loop\n")  # a marker without the list of nnfmu's files (an older nnfmu's)
    refused(loop(ours), MARKER)
    assert (ours / "precious_notes.txt").read_text() == "my notes"
