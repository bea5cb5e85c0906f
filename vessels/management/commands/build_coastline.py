"""Rebuild the offline coastline's static files from the npm package world-atlas (issue 18 §1).

    npm pack world-atlas@2.0.2            # or: curl -O https://registry.npmjs.org/world-atlas/-/world-atlas-2.0.2.tgz
    python manage.py build_coastline world-atlas-2.0.2.tgz

Reads the package file only (no network), checks it is the release the files were made from,
and rewrites vessels/static/vessels/vendor/naturalearth/: the 1:110m and 1:50m land whole, the
1:10m land in 5°×5° cells, in one folder named after their hash (so a browser may keep them
for ever), and index.json, which the maps read first. Run again after changing LEVELS.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import tarfile
from pathlib import Path
from typing import Any

from django.core.management.base import BaseCommand, CommandError, CommandParser

from vessels import coastline

PACKAGE = "world-atlas"
VERSION = "2.0.2"
PACKAGE_SHA256 = "032e7765f2ce00edaeafec23ff22bc3b77e42987c257da944cc585b452c05b97"
OUT = Path(__file__).resolve().parents[2] / "static" / "vessels" / "vendor" / "naturalearth"
# (name, file in the package, cell side in degrees or None for the whole world, grid steps a
# cell side, from which zoom the maps use it). 10m at 8192 steps of 5°: 0.0006° (~60 m), finer
# than the package's own 0.0036° grid; the coarse levels are only drawn zoomed out.
LEVELS: tuple[tuple[str, str, float | None, int, int], ...] = (
    ("110m", "package/land-110m.json", None, 8192, 0),
    ("50m", "package/land-50m.json", None, 16384, 3),
    ("10m", "package/land-10m.json", 5, 8192, 6),
)


def compact(data: Any) -> bytes:
    return json.dumps(data, separators=(",", ":")).encode()


class Command(BaseCommand):
    help = "Rebuild the offline coastline (Natural Earth land) from a world-atlas npm tarball."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("tarball", help=f"{PACKAGE}-{VERSION}.tgz from the npm registry")
        parser.add_argument("--out", default=str(OUT), help="folder to (re)write")

    def handle(self, *args: Any, **opts: Any) -> None:
        tarball, out = Path(opts["tarball"]), Path(opts["out"])
        try:
            data = tarball.read_bytes()
        except OSError as exc:
            raise CommandError(f"cannot read {tarball}: {exc}") from None
        digest = hashlib.sha256(data).hexdigest()
        if digest != PACKAGE_SHA256:
            raise CommandError(
                f"{tarball} is not {PACKAGE} {VERSION} (sha256 {digest}); "
                "a new release: update VERSION and PACKAGE_SHA256, then look at the maps"
            )
        levels = []
        with tarfile.open(tarball) as tar:
            for name, member, size, q, minzoom in LEVELS:
                topology = json.load(tar.extractfile(member))  # type: ignore[arg-type]
                cells = coastline.split(coastline.polygons(topology, "land"), size, q)
                levels.append((name, size, minzoom, {c.name: compact(t) for c, t in cells.items()}))
        self.write(out, levels)

    def write(
        self, out: Path, levels: list[tuple[str, float | None, int, dict[str, bytes]]]
    ) -> None:
        """Every file in a folder named after the hash of them all (12 hex digits), so a browser
        may keep them for ever; index.json beside it says which cells there are."""
        digest = hashlib.sha256()
        for name, _, _, files in levels:
            for cell, body in sorted(files.items()):
                digest.update(f"{name}/{cell}:{len(body)}:".encode() + body)
        version = digest.hexdigest()[:12]
        for old in out.glob("*"):
            if old.is_dir():
                shutil.rmtree(old)
        index: dict[str, Any] = {"source": f"Natural Earth land, npm {PACKAGE} {VERSION}"}
        index["base"], index["levels"] = version + "/", []
        for name, size, minzoom, files in levels:
            (out / version / name).mkdir(parents=True)
            for cell, body in files.items():
                (out / version / name / f"{cell}.json").write_bytes(body)
            index["levels"].append(
                {"name": name, "minzoom": minzoom, "cell": size, "cells": sorted(files)}
            )
            total = sum(len(b) for b in files.values())
            self.stdout.write(f"{name}: {len(files)} file(s), {total:,} bytes")
        (out / "index.json").write_bytes(compact(index) + b"\n")
        self.stdout.write(f"wrote {out / version} and {out / 'index.json'}")
