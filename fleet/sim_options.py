"""What the demo's simulated vessels (manage.py simulate_boat, simulate_glider) read alike from
their command lines: the vessel key and the start position."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from django.core.management.base import CommandError


def vessel_key(opts: dict[str, Any]) -> str:
    """The key from ``--key`` or ``--key-file`` (a file keeps it out of ``ps``)."""
    if opts["key"]:
        return str(opts["key"]).strip()
    if opts["key_file"]:
        try:
            return Path(opts["key_file"]).read_text().strip()
        except OSError as exc:
            raise CommandError(f"cannot read the key file: {exc}") from None
    raise CommandError("give --key or --key-file")


def start_position(text: str) -> tuple[float, float]:
    """``--start`` as (lat, lon)."""
    try:
        lat, lon = (float(v) for v in text.split(","))
    except ValueError:
        raise CommandError("--start must be lat,lon") from None
    return lat, lon
