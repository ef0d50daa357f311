"""Open zip archives from elsewhere (`.ssp` systems, FMUs) safely, and keep paths named inside them inside them.

An archive may name members outside the extraction folder (`../../x`, `/etc/x`: zip-slip), inflate a megabyte into
gigabytes (a zip bomb), or point an SSP element's `source` at FMUs anywhere on disk (an FMU is native code). Every
member is checked before anything is read or written.
"""

from __future__ import annotations

import re
import shutil
import zipfile
from pathlib import Path, PurePosixPath

from nnfmu.errors import NnfmuError
from nnfmu.input_files import not_regular

MAX_TOTAL_BYTES = 256 * 1024 * 1024  # uncompressed size of all members: FMUs of a few MB each fit hundreds of times
MAX_MEMBERS = 10_000  # an FMU or a system has tens
MAX_RATIO = 100.0  # uncompressed / compressed size of a member above RATIO_FLOOR: XML and FMUs stay far below
RATIO_FLOOR = 1024 * 1024  # [bytes] smaller members may compress as well as they like
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")  # a URI scheme or a Windows drive letter


class ArchiveError(NnfmuError, ValueError):
    """An archive member or a path named inside the archive that would reach outside it, or an archive too large to
    unpack."""


def _unsafe(name: str) -> str | None:
    """Why a member or source name cannot stay inside its folder, or None when it can."""
    if not name or "\x00" in name or "\\" in name:
        return "holds a backslash or NUL, or is empty"
    if name.startswith("/") or _SCHEME.match(name):
        return "is absolute"
    if ".." in PurePosixPath(name).parts:
        return "climbs out with '..'"
    return None


def check_members(archive: zipfile.ZipFile, path: Path) -> list[zipfile.ZipInfo]:
    """Every member once its name, its size and its compression ratio are within bounds."""
    members = archive.infolist()
    if len(members) > MAX_MEMBERS:
        raise ArchiveError(f"{path}: {len(members)} members, more than the {MAX_MEMBERS} an archive may hold")
    total = 0
    for member in members:
        why = _unsafe(member.filename)
        if why:
            raise ArchiveError(f"{path}: member {member.filename!r} {why}; refusing to extract the archive")
        ratio = member.file_size / max(member.compress_size, 1)
        if member.file_size > RATIO_FLOOR and ratio > MAX_RATIO:
            raise ArchiveError(
                f"{path}: member {member.filename!r} inflates {ratio:.0f}-fold ({member.compress_size} "
                f"-> {member.file_size} bytes), more than the {MAX_RATIO:g}-fold limit (a zip bomb?)"
            )
        total += member.file_size
        if total > MAX_TOTAL_BYTES:
            raise ArchiveError(
                f"{path}: the members unpack to more than the limit of {MAX_TOTAL_BYTES} bytes "
                f"(reached at {member.filename!r})"
            )
    return members


def open_zip(path: Path) -> zipfile.ZipFile:
    """The zip archive at `path` opened for reading; ArchiveError when it is no regular file (a FIFO's open waits
    for ever, /dev/zero is read without end looking for the archive's directory)."""
    why = not_regular(path)
    if why:
        raise ArchiveError(f"{path}: {why}")
    return zipfile.ZipFile(path)


def check_zip(path: Path) -> None:
    """ArchiveError naming the member when the zip archive at `path` (an FMU) holds one that is unsafe to read or
    extract; zipfile's own errors for a file that is no zip archive."""
    with open_zip(path) as archive:
        check_members(archive, path)


def extract_zip(path: Path, folder: Path) -> None:
    """Extract the zip archive at `path` into the empty `folder`; ArchiveError naming the member when one is
    unsafe, before anything is written."""
    root = folder.resolve()
    with open_zip(path) as archive:
        for member in check_members(archive, path):
            target = (root / member.filename).resolve()
            if root not in target.parents:
                raise ArchiveError(f"{path}: member {member.filename!r} would be written outside the archive's folder")
            if member.is_dir():
                target.mkdir(parents=True, exist_ok=True)
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            with archive.open(member) as source, open(target, "wb") as sink:
                shutil.copyfileobj(source, sink)  # zipfile stops at the declared size and checks the CRC


def confined_source(source: str, folder: Path, where: str) -> Path:
    """The FMU path of an element's `source` inside the extracted archive `folder`; ArchiveError naming the element
    and the source when it is absolute or leads out of the folder."""
    why = _unsafe(source)
    root = folder.resolve()
    if why is None and root not in (root / source).resolve().parents:
        why = "leads out of the archive's folder"
    if why:
        raise ArchiveError(f"{where}: source {source!r} {why}; an .ssp system may only use FMUs inside itself")
    return root / source
