"""The `fence` command: load the vessel's fence set into ArduPilot, switch it on, prove it.

References:
- mavlink.io/en/services/geofence.html: fences travel by the mission protocol
  (:mod:`edge_client.mission`) with mission_type MAV_MISSION_TYPE_FENCE; one item per polygon
  vertex (MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION / _EXCLUSION, param1 the polygon's vertex
  count, x/y its latitude/longitude in 1e-7 degrees) and one per circle
  (MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION / _EXCLUSION, param1 the radius in metres).
- ArduPilot: MissionItemProtocol_Fence (the upload and download), AC_PolyFence_loader (how it
  stores them: whole 1e-7 degrees, a radius as a float), AC_Fence's parameters: FENCE_ENABLE,
  FENCE_TYPE (Rover's bitmask: 2 a circle of FENCE_RADIUS around home, 4 the uploaded
  inclusion/exclusion polygons and circles), FENCE_ACTION (what the boat does on a breach).

Pure: the link (:class:`edge_client.mavlink_link.MavlinkLink`) is handed in; the items and
the read-back check are plain functions, tested without an autopilot.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

from edge_client.commands import CommandError
from edge_client.contract.fence import e7
from edge_client.contract.mavcmd import MavCmd
from edge_client.mission import (
    MAV_FRAME_GLOBAL,
    MAV_MISSION_TYPE_FENCE,
    MissionDownload,
    MissionItem,
    MissionUpload,
    result_name,
)

POLYGON_COMMANDS = {
    True: MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    False: MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
}
CIRCLE_COMMANDS = {
    True: MavCmd.NAV_FENCE_CIRCLE_INCLUSION,
    False: MavCmd.NAV_FENCE_CIRCLE_EXCLUSION,
}
# FENCE_TYPE as Shoreside sets it: the uploaded polygons and circles only (AC_FENCE_TYPE_POLYGON).
# Rover's default, 6, adds a circle of FENCE_RADIUS (300 m) around home, which the shore knows
# nothing of: the autopilot would then enforce a fence the server does not show.
FENCE_TYPE_POLYGON = 4
MAV_PARAM_TYPE_INT8 = 2  # common.xml MAV_PARAM_TYPE; FENCE_ENABLE and FENCE_TYPE are AP_Int8


class FenceLink(Protocol):
    """What this module needs of the MAVLink link (MavlinkLink has it)."""

    def upload_mission(self, items: list[MissionItem], mission_type: int = 0) -> MissionUpload: ...

    def download_mission(self, mission_type: int = 0) -> MissionDownload: ...

    def param_set(self, name: str, value: float, param_type: int) -> float | None: ...


def build_fence_items(fences: Sequence[Mapping[str, Any]]) -> list[MissionItem]:
    """The MAVLink fence items of a set (in the wire shape, already checked), in its order:
    each polygon's vertices in turn, each carrying the vertex count; a circle as one item."""
    items: list[MissionItem] = []

    def add(command: int, lat: float, lon: float, param1: float) -> None:
        items.append(
            MissionItem(
                seq=len(items),
                command=command,
                x=e7(lat),
                y=e7(lon),
                param1=param1,
                frame=MAV_FRAME_GLOBAL,
            )
        )

    for fence in fences:
        inclusion = bool(fence["inclusion"])
        if fence.get("circle") is not None:
            c = fence["circle"]
            add(CIRCLE_COMMANDS[inclusion], c["lat"], c["lon"], float(c["radius_m"]))
            continue
        count = float(len(fence["polygon"]))
        for lat, lon in fence["polygon"]:
            add(POLYGON_COMMANDS[inclusion], lat, lon, count)
    return items


def _as_float32(value: float) -> float:
    """The value as ArduPilot's float storage (and MISSION_ITEM_INT's param1) keeps it."""
    return struct.unpack("<f", struct.pack("<f", value))[0]


def _where(item: MissionItem) -> str:
    return f"item {item.seq} ({mavcmd_short(item.command)} {item.x / 1e7:.7f}, {item.y / 1e7:.7f})"


def mavcmd_short(command: int) -> str:
    try:
        return MavCmd(command).name.removeprefix("NAV_FENCE_").lower()
    except ValueError:
        return f"MAV_CMD {command}"


def readback_mismatch(sent: Sequence[MissionItem], got: Sequence[MissionItem]) -> str:
    """Why the fence read back from the autopilot is not the one sent, "" when it is the same
    vertex for vertex: the same items in the same order, each with the same command, the same
    position in whole 1e-7 degrees and the same vertex count or radius (as a float32)."""
    if len(got) != len(sent):
        return f"the autopilot holds {len(got)} fence items, {len(sent)} were sent"
    for a, b in zip(sent, got, strict=True):
        if (a.command, a.x, a.y) != (b.command, b.x, b.y):
            return f"{_where(a)} was read back as {_where(b)}"
        if not math.isclose(_as_float32(a.param1), b.param1, rel_tol=1e-6, abs_tol=1e-3):
            return f"{_where(a)} param1 {a.param1:g} was read back as {b.param1:g}"
    return ""


def _set(link: FenceLink, name: str, value: int) -> None:
    held = link.param_set(name, value, MAV_PARAM_TYPE_INT8)
    if held is None:
        raise CommandError(f"the autopilot did not answer setting {name} (no such parameter?)")
    if held != value:
        raise CommandError(f"the autopilot kept {name} {held:g} when asked for {value}")


def upload_fence(
    link: FenceLink,
    fences: Sequence[Mapping[str, Any]],
    accepted: Callable[[str], None] = lambda detail: None,
) -> str:
    """Load ``fences`` into the autopilot and switch its fence on; returns what was done.
    Raises :class:`CommandError` with the reason at the first step that fails.

    1. Upload the items (mission_type FENCE); the autopilot replaces its whole fence set and
       ends with MISSION_ACK. ``accepted(detail)`` is called then.
    2. Read the set back and compare it, vertex for vertex (:func:`readback_mismatch`). A
       set that differs is not switched on: the autopilot keeps what it holds, and the
       command fails saying where they differ.
    3. FENCE_TYPE 4 (the uploaded fences, no circle around home) and FENCE_ENABLE 1, each
       by PARAM_SET confirmed by the PARAM_VALUE the autopilot answers. Parameters are saved
       by ArduPilot, so the fence stays on after a reboot at sea (MAV_CMD_DO_FENCE_ENABLE
       would not be).
    """
    items = build_fence_items(fences)
    upload = link.upload_mission(items, MAV_MISSION_TYPE_FENCE)
    if not upload.ok:
        raise CommandError(f"fence upload failed: {upload.error}")
    count = len(fences)
    accepted(f"{count} fence(s), {len(items)} items accepted ({result_name(upload.result)})")
    readback = link.download_mission(MAV_MISSION_TYPE_FENCE)
    if not readback.ok:
        raise CommandError(f"fence uploaded but not read back: {readback.error}; not enabled")
    if differs := readback_mismatch(items, readback.items):
        raise CommandError(f"the fence read back differs from the one sent: {differs}; not enabled")
    _set(link, "FENCE_TYPE", FENCE_TYPE_POLYGON)
    _set(link, "FENCE_ENABLE", 1)
    return (
        f"{count} fence(s), {len(items)} items loaded, read back identical, enabled "
        f"(FENCE_ENABLE 1, FENCE_TYPE {FENCE_TYPE_POLYGON})"
    )
