"""Write files so that a failure never leaves a half-written result behind."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from nnfmu.errors import OutputPathError
from nnfmu.input_files import special_kind
from nnfmu.stopping import check_stop, interrupts_deferred


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


@contextmanager
def scratch_dir(prefix: str, parent: str | os.PathLike[str] | None = None) -> Iterator[Path]:
    """A temporary folder (in `parent`, else TMPDIR) removed with everything in it when the block ends, however it
    ends: unlike tempfile.TemporaryDirectory, an interrupt cannot land between its creation and the armed cleanup."""
    path: Path | None = None
    try:
        with interrupts_deferred():
            path = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
        yield path
    finally:
        with interrupts_deferred():
            if path is not None:
                shutil.rmtree(path, ignore_errors=True)


@contextmanager
def staging_dir(parent: Path, prefix: str) -> Iterator[Path]:
    """A new empty folder in `parent` to build a result in before renaming it into place, with the mode a plain
    mkdir would give (mkdtemp makes 0700, which would hide the renamed result from other users); whatever is still
    there when the block ends (a failure, an interrupt) is removed."""
    with scratch_dir(prefix, parent) as path:
        path.chmod(0o777 & ~_umask())
        yield path


def refuse_special(target: Path, option: str = "output") -> None:
    """OutputPathError when `target` exists (links followed) and is not a regular file: a device such as /dev/null,
    a FIFO or a socket would be replaced by the regular file renamed onto its name."""
    try:
        os.stat(target)
    except (FileNotFoundError, NotADirectoryError):
        return
    except OSError as error:
        raise OutputPathError(f"{option} {target}: cannot be checked ({error.strerror})") from None
    kind = special_kind(target)
    if kind is not None:
        raise OutputPathError(
            f"{option} {target}: is {kind}, not a regular file; nnfmu writes only new names or regular files "
            f"(writing would replace it), so give another path"
        )


@contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside `target`; rename it onto `target` only if the block succeeds and no stop was
    asked for (`stopping`)."""
    target = Path(target)
    refuse_special(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp_path: Path | None = None
    try:
        with interrupts_deferred():
            fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
            os.close(fd)
            tmp_path = Path(tmp)
        tmp_path.chmod(0o666 & ~_umask())  # mkstemp makes 0600; give the result the mode a plain open() would
        yield tmp_path
        check_stop()
        os.replace(tmp_path, target)
    finally:
        if tmp_path is not None and tmp_path.exists():
            tmp_path.unlink()


def write_text_atomic(target: str | os.PathLike[str], text: str) -> None:
    """Write `text` to `target` via a temporary file and a rename."""
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")
