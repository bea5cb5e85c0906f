"""A simulated boat for demos and load: position, course and sensor readings. Pure (no I/O).

`manage.py simulate_boat` drives it over real HTTP; this module only moves the boat and decides
what each command does to it.
"""

from __future__ import annotations

import datetime as dt
import random
from dataclasses import dataclass, field
from typing import Any

from telemetry.geo import bearing_deg, distance_m, offset

ARRIVED_M = 10.0


def patrol_route(
    lat: float, lon: float, radius_m: float = 400, points: int = 6
) -> list[tuple[float, float]]:
    return [offset(lat, lon, 360 * i / points, radius_m) for i in range(points)]


@dataclass
class SimBoat:
    lat: float
    lon: float
    speed_mps: float = 2.0
    route: list[tuple[float, float]] = field(default_factory=list)
    mode: str = "AUTO"  # AUTO follows `route`, GUIDED goes to `target`, HOLD stays
    armed: bool = True
    loop: bool = True
    battery_v: float = 13.2
    heading_deg: float = 0.0
    target: tuple[float, float] | None = None
    leg: int = 0
    rng: random.Random = field(default_factory=lambda: random.Random(1))

    def __post_init__(self) -> None:
        self.home = (self.lat, self.lon)

    @property
    def moving(self) -> bool:
        return self.armed and self.mode in {"AUTO", "GUIDED", "RTL"} and self._goal() is not None

    def _goal(self) -> tuple[float, float] | None:
        if self.mode in {"GUIDED", "RTL"}:
            return self.target
        if self.mode == "AUTO" and self.route:
            return self.route[self.leg % len(self.route)]
        return None

    def step(self, seconds: float) -> None:
        """Advance the boat by ``seconds`` of simulated time."""
        self.battery_v = max(10.5, self.battery_v - 0.00002 * seconds * (2 if self.moving else 1))
        goal = self._goal()
        if not self.moving or goal is None:
            return
        remaining = distance_m(self.lat, self.lon, *goal)
        self.heading_deg = bearing_deg(self.lat, self.lon, *goal)
        travel = self.speed_mps * seconds
        if travel >= remaining:
            self.lat, self.lon = goal
            self._arrived()
        else:
            self.lat, self.lon = offset(self.lat, self.lon, self.heading_deg, travel)

    def _arrived(self) -> None:
        if self.mode == "AUTO" and self.route:
            self.leg += 1
            if self.leg >= len(self.route) and not self.loop:
                self.mode, self.leg = "HOLD", len(self.route) - 1
        elif self.mode in {"GUIDED", "RTL"}:
            self.mode = "HOLD"

    def arrived_at(self, lat: float, lon: float) -> bool:
        return distance_m(self.lat, self.lon, lat, lon) <= ARRIVED_M

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

    def execute(self, kind: str, params: dict[str, Any]) -> tuple[str, str]:
        """Apply a command; return (status, detail) to ack now: acknowledged, done or failed."""
        if kind == "move_to":
            self.mode, self.target = "GUIDED", (params["lat"], params["lon"])
            return "acknowledged", "GUIDED target set"
        if kind == "hold":
            self.mode = "HOLD"
            return "done", "holding"
        if kind == "resume":
            self.mode = "AUTO"
            return "done", "AUTO"
        if kind == "return_home":
            self.mode, self.target = "RTL", self.home
            return "acknowledged", "returning home"
        if kind == "set_mode":
            self.mode = params["mode"]
            if self.mode == "RTL":
                self.target = self.home
            return "done", f"mode {self.mode}"
        if kind in {"arm", "disarm"}:
            self.armed = kind == "arm"
            return "done", kind + "ed"
        if kind == "mission":
            self.route = [(i["lat"], i["lon"]) for i in params["items"]]
            self.loop, self.leg, self.mode = bool(params.get("loop")), 0, "AUTO"
            return "acknowledged", f"mission of {len(self.route)} items loaded"
        return "failed", f"unsupported command {kind}"

    def finished(self, kind: str, params: dict[str, Any]) -> bool:
        """Whether an acknowledged command has now completed."""
        if kind == "move_to":
            return self.arrived_at(params["lat"], params["lon"])
        if kind == "return_home":
            return self.arrived_at(*self.home)
        if kind == "mission":
            return self.mode == "HOLD" or (self.loop and self.leg >= len(self.route))
        return True
