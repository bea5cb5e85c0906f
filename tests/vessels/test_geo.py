"""Geo helpers, server side (vessels/geo.py), and their agreement with the boat's copy."""

from __future__ import annotations

import pytest

from edge_client import geo as edge_geo
from vessels import geo

FREMANTLE = (-32.0560, 115.7400)


def test_one_minute_of_latitude_is_about_a_nautical_mile() -> None:
    assert geo.distance_m(0, 0, 1 / 60, 0) == pytest.approx(1853.2, abs=0.5)


@pytest.mark.parametrize("bearing", [0, 45, 90, 180, 270, 359])
def test_an_offset_lands_at_its_distance_and_bearing(bearing: float) -> None:
    there = geo.offset(*FREMANTLE, bearing, 600)
    assert geo.distance_m(*FREMANTLE, *there) == pytest.approx(600, abs=0.5)
    assert geo.bearing_deg(*FREMANTLE, *there) == pytest.approx(bearing % 360, abs=0.1)


def test_bearings_run_from_0_to_360() -> None:
    assert geo.bearing_deg(0, 0, 0, 1) == pytest.approx(90)
    assert geo.bearing_deg(0, 0, 0, -1) == pytest.approx(270)
    assert geo.distance_m(*FREMANTLE, *FREMANTLE) == 0


def test_the_boats_copy_gives_the_same_answers() -> None:
    there = geo.offset(*FREMANTLE, 123, 4567)
    assert edge_geo.offset(*FREMANTLE, 123, 4567) == there
    assert edge_geo.distance_m(*FREMANTLE, *there) == geo.distance_m(*FREMANTLE, *there)
    assert edge_geo.bearing_deg(*FREMANTLE, *there) == geo.bearing_deg(*FREMANTLE, *there)
    assert edge_geo.EARTH_RADIUS_M == geo.EARTH_RADIUS_M
