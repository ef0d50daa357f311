"""Content hashes: of files (SHA-256 of their bytes) and of a case's inputs (SHA-256 of canonical JSON)."""

from __future__ import annotations

import hashlib
import json
import os
import stat
from pathlib import Path
from typing import Any

from nnfmu.workflows.campaign.errors import CampaignError

CHUNK = 1 << 20  # bytes read at a time when hashing a file
MAX_FILE_BYTES = 4 * 1024**3  # a campaign's input file (drive, FMU): a 1 kHz float64 drive of 4 channels is 32 kB/s


def _chunks(path: Path, limit: int = MAX_FILE_BYTES) -> Any:
    """The bytes of a regular file of at most `limit` bytes, a chunk at a time; CampaignError naming the file for
    anything else (a device or FIFO would never end, a file that grows while read is cut off at the limit)."""
    with open(path, "rb") as handle:
        if not stat.S_ISREG(os.fstat(handle.fileno()).st_mode):
            raise CampaignError(f"{path}: is not a regular file (a device, FIFO or socket is never read)")
        read = 0
        while chunk := handle.read(CHUNK):
            read += len(chunk)
            if read > limit:
                raise CampaignError(f"{path}: larger than the {limit} bytes a campaign's input file may be")
            yield chunk


def file_sha256(path: Path) -> str:
    """SHA-256 of the file's bytes, hex (a regular file of at most MAX_FILE_BYTES)."""
    digest = hashlib.sha256()
    for chunk in _chunks(path):
        digest.update(chunk)
    return digest.hexdigest()


def file_bytes(path: Path, limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of a regular file of at most `limit` bytes."""
    return b"".join(_chunks(path, limit))


def bytes_sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def canonical_json(value: Any) -> str:
    """JSON with sorted keys and no spaces, so equal inputs give equal text (and equal hashes)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)


def json_sha256(value: Any) -> str:
    return hashlib.sha256(canonical_json(value).encode("utf-8")).hexdigest()
