"""A boat's track for the demo's history: a patrol route, walked at a steady speed. Pure.

``seed_demo`` uses it to give each demo vessel a few hours of fixes before the real edge
client (``simulate_boat``: the Rover simulator plus ``python -m edge_client``) takes over.
It only moves a point and makes up plausible readings; it runs no commands.
"""

from __future__ import annotations

import datetime as dt
import random
from dataclasses import dataclass, field
from typing import Any

from edge_client.contract.geo import bearing_deg, distance_m, offset


def patrol_route(
    lat: float, lon: float, radius_m: float = 400, points: int = 6
) -> list[tuple[float, float]]:
    """``points`` waypoints on a circle of ``radius_m`` around (lat, lon), clockwise from north."""
    return [offset(lat, lon, 360 * i / points, radius_m) for i in range(points)]


@dataclass
class SimBoat:
    """A point that follows ``route`` round and round at ``speed_mps``."""

    lat: float
    lon: float
    speed_mps: float = 2.0
    route: list[tuple[float, float]] = field(default_factory=list)
    battery_v: float = 13.2
    heading_deg: float = 0.0
    leg: int = 0
    rng: random.Random = field(default_factory=lambda: random.Random(1))

    @property
    def moving(self) -> bool:
        return bool(self.route)

    def step(self, seconds: float) -> None:
        """Advance the boat by ``seconds`` of simulated time."""
        self.battery_v = max(10.5, self.battery_v - 0.00002 * seconds * (2 if self.moving else 1))
        if not self.route:
            return
        goal = self.route[self.leg % len(self.route)]
        remaining = distance_m(self.lat, self.lon, *goal)
        self.heading_deg = bearing_deg(self.lat, self.lon, *goal)
        travel = self.speed_mps * seconds
        if travel >= remaining:
            self.lat, self.lon = goal  # the rest of the step is lost turning: fine for a demo
            self.leg += 1
        else:
            self.lat, self.lon = offset(self.lat, self.lon, self.heading_deg, travel)

    def fix(self, now: dt.datetime) -> dict[str, Any]:
        """A v1 telemetry record with plausible sensor readings."""
        return {
            "time": now.isoformat(),
            "lat": round(self.lat, 7),
            "lon": round(self.lon, 7),
            "heading_deg": round(self.heading_deg, 1),
            "speed_mps": round(self.speed_mps if self.moving else 0.0, 2),
            "battery_v": round(self.battery_v, 2),
            "readings": {
                "water_temp_c": round(19.0 + self.rng.gauss(0, 0.15), 2),
                "salinity_psu": round(35.4 + self.rng.gauss(0, 0.05), 2),
                "humidity_pct": round(48 + self.rng.gauss(0, 1.0), 1),
            },
        }
