"""What kind of file a path names, so that an input that is no regular file (a FIFO, whose open waits for a writer
for ever; a device such as /dev/zero, which never ends) is refused by name before it is opened."""

from __future__ import annotations

import os
import stat
from pathlib import Path


def special_kind(path: Path) -> str | None:
    """'a FIFO', 'a socket' or 'a device' when `path` (links followed) exists and is neither a regular file nor a
    folder; None otherwise (also when it does not exist or cannot be looked at: the caller's open says why)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"


def not_regular(path: Path) -> str | None:
    """The end of a one-line refusal ('is a FIFO, not a regular file ...') for an input that is no regular file."""
    kind = special_kind(path)
    return None if kind is None else f"is {kind}, not a regular file (nnfmu reads its inputs only from regular files)"
