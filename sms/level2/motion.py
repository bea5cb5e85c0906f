"""Where the simulated C&C's glider is: it moves as the Level-1 commands it receives say.

The C&C simulator reports a position in every status request with a fix (§8.3; § as in
docs/level2.md#section-numbers-in-the-code). With a :class:`Motion` the position is no longer
fixed: the glider follows a heading, steers for the last waypoint it was sent, or holds
station, at a constant speed, as a Wave Glider does between commands. Only what a demo and its
tests need: no current, no wave speed, no turning radius. Pure (no I/O); the simulator asks for
the position with its own clock's time.

Command values (§11.1, as ``inner_commands.toml`` encodes them; a test checks that the two
agree): 0x0008 follow fixed heading (heading u16 little-endian in parameter bytes 3–4),
0x0002 hold station, 0x8000 new waypoint (latitude and longitude as minutes × 10⁴).
"""

from __future__ import annotations

from dataclasses import dataclass

from edge_client.contract.geo import bearing_deg, distance_m, offset

from .bodies import CommandPacket
from .fields import l2_to_degrees

FHEAD = 0x0008
HOLD = 0x0002
WAYPOINT = 0x8000
ARRIVED_M = 30.0  # a waypoint this close is reached: the glider holds there
# Longer steps are cut into pieces this long, so a course for a waypoint does not overshoot
# it when polls are far apart (a demo's C&C may be paused, or time compressed in a test).
MAX_STEP_S = 5.0


@dataclass
class Motion:
    """A glider at (``lat``, ``lon``) doing ``speed_mps`` on ``heading_deg`` (mode "heading"),
    towards ``target`` (mode "waypoint") or holding station (mode "hold")."""

    lat: float
    lon: float
    heading_deg: float = 0.0
    speed_mps: float = 1.0
    mode: str = "heading"
    target: tuple[float, float] | None = None
    at: float | None = None  # the clock time the position is for; None: not started

    def position(self, now: float) -> tuple[float, float]:
        """The position at clock time ``now`` (advancing from the last call)."""
        if self.at is None:
            self.at = now
        while now > self.at:
            step = min(now - self.at, MAX_STEP_S)
            self._advance(step)
            self.at += step
        return self.lat, self.lon

    def obey(self, packet: CommandPacket, now: float) -> str | None:
        """Act on a command the C&C accepted; what it now does, or None if it does not move it."""
        self.position(now)  # the old course up to now, the new one from now on
        if packet.value == FHEAD:
            self.heading_deg = int.from_bytes(packet.params[3:5], "little") % 360
            self.mode, self.target = "heading", None
        elif packet.value == HOLD:
            self.mode, self.target = "hold", None
        elif packet.value == WAYPOINT:
            self.target = (l2_to_degrees(packet.lat), l2_to_degrees(packet.lon))
            self.mode = "waypoint"
            self.heading_deg = bearing_deg(self.lat, self.lon, *self.target)
        else:
            return None
        return self.describe()

    def describe(self) -> str:
        if self.mode == "hold":
            return f"holding station at {self.lat:.5f},{self.lon:.5f}"
        if self.mode == "waypoint" and self.target is not None:
            return (
                f"steering {self.heading_deg:03.0f}° for {self.target[0]:.5f},{self.target[1]:.5f}"
            )
        return f"following heading {self.heading_deg:03.0f}° at {self.speed_mps:g} m/s"

    def _advance(self, seconds: float) -> None:
        if self.mode == "hold" or seconds <= 0:
            return
        metres = self.speed_mps * seconds
        if self.mode == "waypoint" and self.target is not None:
            left = distance_m(self.lat, self.lon, *self.target)
            if left <= max(ARRIVED_M, metres):
                self.lat, self.lon = self.target
                self.mode, self.target = "hold", None  # arrived: station keeping
                return
            self.heading_deg = bearing_deg(self.lat, self.lon, *self.target)
        self.lat, self.lon = offset(self.lat, self.lon, self.heading_deg, metres)
