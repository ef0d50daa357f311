"""Check output paths before anything is written, so that no command deletes or replaces what nnfmu did not write.

A result file must not be one of the command's inputs, a folder, a device, a FIFO or a socket, or lie under a file.
A result folder that nnfmu replaces or fills must be new, empty, or an earlier nnfmu output of the same kind (a marker
file inside says which command wrote it), and must hold neither an input nor the current folder. A folder nnfmu
replaces as a whole (the loops') has its marker list every file nnfmu wrote there with its size and SHA-256: a re-run
replaces only those, unchanged, and keeps every other file; a listed file changed since is refused before work starts.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from collections.abc import Iterable
from pathlib import Path

from nnfmu.atomic import refuse_special
from nnfmu.errors import OutputPathError
from nnfmu.stopping import check_stop, interrupts_deferred

__all__ = [
    "MARKER",
    "OutputPathError",
    "check_output_dir",
    "check_output_file",
    "file_output",
    "mark_output_dir",
    "marker_kind",
    "replace_output_dir",
]

MARKER = ".nnfmu-output"  # inside every result folder: the kind of output (loop, validate, batch, demo) on line 1
LISTED = "files:"  # line 2 of a replaced folder's marker; then one `SIZE SHA256 PATH` line per file nnfmu wrote


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
    lines = _marker_lines(folder)
    return lines[0].strip() or None if lines else None


def _marker_lines(folder: Path) -> list[str]:
    """The marker's lines, none when it is missing or unreadable (a marker is small: 1 MiB at most is read)."""
    try:
        with open(folder / MARKER, encoding="utf-8") as f:
            return f.read(1 << 20).splitlines()
    except (OSError, UnicodeDecodeError):
        return []


def _listed(folder: Path) -> dict[str, tuple[int, str]] | None:
    """{relative path: (size, SHA-256)} of the files the marker says nnfmu wrote; None for a marker without a list."""
    lines = _marker_lines(folder)
    if len(lines) < 2 or lines[1] != LISTED:
        return None
    files = {}
    for line in lines[2:]:
        size, digest, name = (line.split(" ", 2) + ["", ""])[:3]
        if size.isdigit() and len(digest) == 64 and name:
            files[name] = (int(size), digest)
    return files


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (hex), read a MiB at a time."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _entries(folder: Path) -> list[Path]:
    """Everything below `folder` except its marker, as relative paths, links not followed, parents first."""
    found = []
    for root, dirs, files in os.walk(folder):
        here = Path(root).relative_to(folder)
        found += [here / d for d in sorted(dirs)] + [here / f for f in sorted(files)]
    return [p for p in found if p != Path(MARKER)]


def _unchanged(folder: Path, name: str, listed: dict[str, tuple[int, str]]) -> bool:
    """Whether `name` is a regular file that the marker lists with its present size and SHA-256."""
    path = folder / name
    if name not in listed or path.is_symlink() or not path.is_file():
        return False
    size, digest = listed[name]
    return path.stat().st_size == size and file_digest(path) == digest


def _foreign(folder: Path, listed: dict[str, tuple[int, str]]) -> list[Path]:
    """What in `folder` nnfmu did not write: files and links not listed unchanged, and folders holding no listed
    file (a user's empty folder). Folders whose content is all foreign are given whole, not file by file."""
    theirs: list[Path] = []
    ours = {p for name in listed for p in Path(name).parents}
    for entry in _entries(folder):
        if any(t in entry.parents for t in theirs):
            continue
        path = folder / entry
        if path.is_dir() and not path.is_symlink():
            if entry not in ours:
                theirs.append(entry)
        elif not _unchanged(folder, entry.as_posix(), listed):
            theirs.append(entry)
    return theirs


def check_output_dir(
    out: str | os.PathLike[str],
    kind: str,
    inputs: Iterable[str | os.PathLike[str]] = (),
    option: str = "--out",
    replaces: bool = False,
) -> Path:
    """`out` as a Path once it is safe for a `kind` command to replace or fill it: not a file, holding neither an
    input nor the current folder, and new, empty or an earlier `kind` output (its marker says so). A command that
    `replaces` the folder as a whole (`replace_output_dir`) also needs the marker's list of files nnfmu wrote, each
    unchanged where it is still there: the files of the user's that the new result would replace are refused
    before any work, the others are kept."""
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
        if replaces:
            _check_replaceable(out, kind, option)
    return out


def _check_replaceable(out: Path, kind: str, option: str) -> None:
    """OutputPathError unless the marker lists what nnfmu wrote in `out` and each listed file still there is
    unchanged (a changed one would be replaced by the new result's file of the same name)."""
    listed = _listed(out)
    if listed is None:
        raise OutputPathError(
            f"{option} {out}: its {MARKER} does not list the files nnfmu wrote there (an older nnfmu's {kind} result, "
            f"or a copied marker), so nnfmu cannot tell them from yours; give a new folder, or remove this one yourself"
        )
    changed = [name for name in sorted(listed) if (out / name).exists() and not _unchanged(out, name, listed)]
    if changed:
        raise OutputPathError(
            f"{option} {out}: {out / changed[0]} was changed since nnfmu wrote it (not the size and SHA-256 its "
            f"{MARKER} lists), and the new {kind} result would replace it; move it out of the folder or give a new one"
        )


def mark_output_dir(folder: Path, kind: str) -> None:
    """Write the marker that lets a later `kind` run fill `folder` again."""
    (folder / MARKER).write_text(f"{kind}\n", encoding="utf-8")


def replace_output_dir(staging: Path, out_dir: Path, kind: str) -> None:
    """Put the finished `kind` result `staging` (every file in it nnfmu's, listed in its marker) in place of
    `out_dir`, which `check_output_dir(..., replaces=True)` allowed: the old folder's files that its marker lists
    unchanged go, every other file and folder is moved into the new result. OutputPathError, with the old folder
    untouched, when the new result has a file where one of those is."""
    files = [p for p in _entries(staging) if (staging / p).is_file()]
    lines = [kind, LISTED] + [
        f"{(staging / p).stat().st_size} {file_digest(staging / p)} {p.as_posix()}" for p in files
    ]
    (staging / MARKER).write_text("\n".join(lines) + "\n", encoding="utf-8")
    check_stop()  # a run asked to stop publishes nothing, even where its interrupt was swallowed
    if not out_dir.exists():
        os.replace(staging, out_dir)
        return
    keep = _foreign(out_dir, _listed(out_dir) or {})
    clash = [p for p in keep if os.path.lexists(staging / p)]
    if clash:
        raise OutputPathError(
            f"{out_dir / clash[0]}: is not nnfmu's (not listed unchanged in {out_dir / MARKER}) and the new {kind} "
            f"result has a file of that name; move it out of the folder and run again"
        )
    with interrupts_deferred():  # an interrupt between the renames would leave the old result hidden in .old-
        old = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.old-", dir=out_dir.parent))
        os.replace(out_dir, old / out_dir.name)
        os.replace(staging, out_dir)
        for entry in keep:
            (out_dir / entry).parent.mkdir(parents=True, exist_ok=True)
            os.replace(old / out_dir.name / entry, out_dir / entry)
        shutil.rmtree(old)
