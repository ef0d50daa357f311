"""Check output paths before anything is written, so that no command deletes or replaces what nnfmu did not write.

A result file must not be one of the command's inputs, a folder, or lie under a file. A result folder that nnfmu
replaces or fills must be new, empty, or an earlier nnfmu output of the same kind (a marker file inside says which
command wrote it), and must hold neither an input nor the current folder.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from nnfmu.atomic import refuse_special
from nnfmu.errors import OutputPathError

__all__ = [
    "MARKER",
    "OutputPathError",
    "check_output_dir",
    "check_output_file",
    "file_output",
    "mark_output_dir",
    "marker_kind",
]

MARKER = ".nnfmu-output"  # one line inside every result folder: the kind of output (loop, validate, batch, demo)


def _real(path: str | os.PathLike[str]) -> Path:
    """The absolute path with links and `..` resolved (also for paths that do not exist yet)."""
    return Path(os.path.realpath(path))


def _same(a: Path, b: Path) -> bool:
    """Whether `a` and `b` name the same file: the same resolved path, or the same inode (a hard link)."""
    if _real(a) == _real(b):
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _inside(path: Path, folder: Path) -> bool:
    """Whether `path` is `folder` or lies anywhere below it (both resolved)."""
    path, folder = _real(path), _real(folder)
    return path == folder or folder in path.parents


def file_output(text: str | os.PathLike[str], option: str = "--out") -> Path:
    """The path of a result file given on the command line; refuses an empty path and a trailing slash (which names
    a folder, where a plain Path would silently write a file of the folder's name)."""
    raw = os.fspath(text)
    if not raw.strip():
        raise OutputPathError(f"{option} is empty; give the path of the file to write")
    if raw.endswith(("/", os.sep)):
        raise OutputPathError(
            f"{option} {raw}: ends with a slash, so it names a folder; give the path of a "
            f"file (inside it, if that is where it should go)"
        )
    return Path(raw)


def check_output_file(
    out: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str]], option: str = "--out"
) -> Path:
    """`out` as a Path once it is safe to write a file there: not one of `inputs`, not an existing folder, not
    under a file. OutputPathError naming the path otherwise."""
    out = file_output(out, option)
    for given in inputs:
        if _same(out, Path(given)):
            raise OutputPathError(
                f"{option} {out}: is the input {given}; writing it would destroy the input, so give another path"
            )
    if out.is_dir():
        raise OutputPathError(f"{option} {out}: is an existing folder; give a file path (e.g. inside it)")
    refuse_special(out, option)
    for parent in out.parents:
        if parent.exists() and not parent.is_dir():
            raise OutputPathError(f"{option} {out}: {parent} is a file, not a folder")
    return out


def marker_kind(folder: Path) -> str | None:
    """The kind written in `folder`'s marker, or None when there is none (or it cannot be read)."""
    try:
        return (folder / MARKER).read_text(encoding="utf-8").strip() or None
    except (OSError, UnicodeDecodeError):
        return None


def check_output_dir(
    out: str | os.PathLike[str], kind: str, inputs: Iterable[str | os.PathLike[str]] = (), option: str = "--out"
) -> Path:
    """`out` as a Path once it is safe for a `kind` command to replace or fill it: not a file, holding neither an
    input nor the current folder, and new, empty or an earlier `kind` output (its marker says so)."""
    raw = os.fspath(out)
    if not raw.strip():
        raise OutputPathError(f"{option} is empty; give the folder to write into")
    out = Path(raw)
    if out.exists() and not out.is_dir():
        raise OutputPathError(f"{option} {out}: is a file, not a folder")
    for parent in out.parents:
        if parent.exists() and not parent.is_dir():
            raise OutputPathError(f"{option} {out}: {parent} is a file, not a folder")
    for given in inputs:
        if _inside(Path(given), out):
            raise OutputPathError(
                f"{option} {out}: holds the input {given}, which writing the {kind} result there "
                f"would delete or replace; give a new folder"
            )
    if _inside(Path.cwd(), out):
        raise OutputPathError(
            f"{option} {out}: is the current folder or holds it; give a new folder for the {kind} result"
        )
    if out.is_dir() and any(out.iterdir()):
        found = marker_kind(out)
        if found != kind:
            earlier = f"an earlier nnfmu {found} output" if found else "not an earlier nnfmu output"
            raise OutputPathError(
                f"{option} {out}: the folder is not empty and is {earlier}, not a {kind} result (no {MARKER} file "
                f"saying {kind!r}); nnfmu replaces only what it wrote, so give a new or empty folder, or remove "
                f"this one yourself"
            )
    return out


def mark_output_dir(folder: Path, kind: str) -> None:
    """Write the marker that lets a later `kind` run replace `folder`."""
    (folder / MARKER).write_text(f"{kind}\n", encoding="utf-8")
