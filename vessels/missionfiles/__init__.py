"""Mission files in and out: QGroundControl `.plan`, Mission Planner `.waypoints`, GeoJSON.

Pure: bytes in, a :class:`MissionFile` out (or a MissionFileError naming every problem), and
back. ``vessels.services.mission_import`` / ``mission_export`` do the database side.
"""

from __future__ import annotations

from dataclasses import dataclass

from vessels.errors import MissionFileError
from vessels.missionfiles import geojson, plan, waypoints
from vessels.missionfiles.model import Item, MissionFile

__all__ = [
    "FORMATS",
    "MAX_FILE_BYTES",
    "Item",
    "MissionFile",
    "check_request_size",
    "check_size",
    "detect",
    "dump",
    "load",
]

FORMATS = ("plan", "waypoints", "geojson")
# The largest mission ArduPilot stores (724 items) is under 0.5 MB in any of these formats; a
# file many times that is not a mission, and is refused before it is read into memory.
MAX_FILE_BYTES = 5 * 1024 * 1024
# An upload's body is the file plus its multipart headers and the form's few other fields.
MULTIPART_ALLOWANCE_BYTES = 64 * 1024
_BY_EXTENSION = {
    "plan": "plan",
    "waypoints": "waypoints",
    "txt": "waypoints",
    "geojson": "geojson",
    "json": "geojson",
}
_LOADERS = {"plan": plan.load, "waypoints": waypoints.load, "geojson": geojson.load}


@dataclass(frozen=True)
class Exported:
    content: str
    content_type: str
    extension: str


def detect(*, filename: str = "", content: bytes | str = b"") -> str:
    """The format of a file, by its extension, else by its first bytes."""
    extension = filename.rsplit(".", 1)[-1].lower() if "." in filename else ""
    if extension in _BY_EXTENSION:
        found = _BY_EXTENSION[extension]
        # QGC writes `.plan`, but a `.json` may be a plan too.
        if found == "geojson" and _head(content).find('"fileType"') >= 0:
            return "plan"
        return found
    head = _head(content).lstrip("\ufeff \t\r\n")
    if head.startswith("QGC WPL"):
        return "waypoints"
    if head.startswith("{"):
        return "plan" if '"fileType"' in head else "geojson"
    raise MissionFileError(
        f"cannot tell the format of {filename or 'the file'}: "
        "use a .plan, .waypoints or .geojson file (or name the format)"
    )


def _head(content: bytes | str) -> str:
    head = content[:4096]
    return head.decode("utf-8", "replace") if isinstance(head, bytes) else head


def check_size(size: int) -> None:
    if size > MAX_FILE_BYTES:
        raise MissionFileError(
            f"the file is {size / 1e6:.1f} MB; a mission file is at most "
            f"{MAX_FILE_BYTES / 1e6:.1f} MB"
        )


def check_request_size(content_length: str | None) -> None:
    """Refuse an upload whose declared body (CONTENT_LENGTH) cannot hold a file within the
    limit, before any of it is read: Django spools file parts to disk whatever
    DATA_UPLOAD_MAX_MEMORY_SIZE says."""
    try:
        declared = int(content_length or 0)
    except ValueError:
        return  # no usable length: the file's own size is checked once it is read
    if declared > MAX_FILE_BYTES + MULTIPART_ALLOWANCE_BYTES:
        raise MissionFileError(
            f"the upload is {declared / 1e6:.1f} MB; a mission file is at most "
            f"{MAX_FILE_BYTES / 1e6:.1f} MB"
        )


def load(
    content: bytes | str,
    *,
    format: str | None = None,
    filename: str = "",
    skip_unsupported: bool = False,
    name: str = "",
) -> MissionFile:
    """Read a mission file; raises MissionFileError (and only that) for anything it cannot."""
    check_size(len(content))
    format = format or detect(filename=filename, content=content)
    if format not in _LOADERS:
        raise MissionFileError(f"unknown format {format!r} (known: {', '.join(FORMATS)})")
    return _LOADERS[format](content, skip_unsupported=skip_unsupported, name=name)


def dump(mission: MissionFile, format: str, *, cruise_speed_mps: float) -> Exported:
    if format == "plan":
        content = plan.dump(mission, cruise_speed_mps=cruise_speed_mps)
        return Exported(content, plan.CONTENT_TYPE, plan.EXTENSION)
    if format == "waypoints":
        return Exported(waypoints.dump(mission), waypoints.CONTENT_TYPE, waypoints.EXTENSION)
    if format == "geojson":
        return Exported(geojson.dump(mission), geojson.CONTENT_TYPE, geojson.EXTENSION)
    raise MissionFileError(f"unknown format {format!r} (known: {', '.join(FORMATS)})")
