"""Mission Planner / "QGC WPL" `.waypoints` files (text), read and written. Pure.

Format: docs/missions.md#files (mavlink.io/en/file_formats): a `QGC WPL 110`
header, then one TAB-separated line of 12 fields per item: INDEX CURRENT FRAME COMMAND
PARAM1..4 LAT LON ALT AUTOCONTINUE. Row 0 is ArduPilot's home, not a waypoint; a DO_JUMP
targets an INDEX.
"""

from __future__ import annotations

import math
import re

from vessels.errors import MissionFileError
from vessels.missionfiles import mavitems
from vessels.missionfiles.model import MissionFile, known_home, position, text

CONTENT_TYPE = "text/plain; charset=utf-8"
EXTENSION = "waypoints"
HEADER = "QGC WPL 110"
FIELDS = 12
_HEADER = re.compile(r"QGC WPL \d+")
# Mission Planner writes CRLF; readers (mavros, Mission Planner) take LF too.
NEWLINE = "\r\n"


def load(content: bytes | str, *, skip_unsupported: bool = False, name: str = "") -> MissionFile:
    lines = [line for line in text(content).splitlines() if line.strip()]
    if not lines or not _HEADER.fullmatch(lines[0].strip()):
        raise MissionFileError('not a Mission Planner waypoints file: no "QGC WPL 110" header')
    rows = [_row(n, line) for n, line in enumerate(lines[1:], start=2)]
    home = None
    if rows and rows[0].number == 0:
        home_row, rows = rows[0], rows[1:]
        home = known_home(*position("row 0 (home)", home_row.params[4], home_row.params[5]))
    return mavitems.read(rows, skip_unsupported=skip_unsupported, home=home, name=name)


def _row(line_number: int, line: str) -> mavitems.RawItem:
    fields = line.split("\t") if "\t" in line else line.split()
    where = f"line {line_number}"
    if len(fields) != FIELDS:
        raise MissionFileError(
            f"{where}: {len(fields)} fields; a waypoint line has {FIELDS}, TAB-separated"
        )
    try:
        index, _current, frame, command = (int(f) for f in fields[:4])
        params = tuple(float(f) for f in fields[4:11])
        int(fields[11])
    except ValueError:
        raise MissionFileError(
            f"{where}: INDEX, CURRENT, FRAME, COMMAND and AUTOCONTINUE must be whole numbers "
            "and PARAM1..7 numbers"
        ) from None
    return mavitems.RawItem(index, command, frame, params, jump_id=index)


def dump(mission: MissionFile) -> str:
    lat, lon = mission.home or (0.0, 0.0)
    lines = [
        HEADER,
        _line(0, 1, mavitems.FRAME_GLOBAL, mavitems.NAV_WAYPOINT, (0,) * 4 + (lat, lon, 0)),
    ]
    for row in mavitems.write(mission):
        lines.append(_line(row.number, 0, row.frame, row.command or 0, row.params))
    return NEWLINE.join(lines) + NEWLINE


def _line(index: int, current: int, frame: int, command: int, params: tuple[float, ...]) -> str:
    # repr: the shortest text that reads back as the same float (a lossless round trip);
    # NaN (yaw: "unchanged") as 0, which is what Mission Planner writes.
    values = ["0" if math.isnan(p) else repr(float(p)) for p in params]
    return "\t".join([str(index), str(current), str(frame), str(command), *values, "1"])
