"""Files only their owner may read (the generated secret key, the demo's keys, SQLite's)."""

from __future__ import annotations

import os
from pathlib import Path


def create_private(path: Path) -> None:
    """Create an empty file only its owner can read; an existing file is left alone."""
    try:
        os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
    except (FileExistsError, FileNotFoundError):  # no folder: its user will say so
        pass


def write_private(path: Path, text: str) -> None:
    """Write a file only its owner can read, from the first byte (no chmod-after window)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as handle:
        handle.write(text)
