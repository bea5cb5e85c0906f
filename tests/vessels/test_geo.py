"""The contract's geometry (edge_client/contract/geo.py), which the server and the boat share."""

from __future__ import annotations

import pytest

from edge_client import geo as edge_geo
from edge_client.contract import geo

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


def test_the_old_edge_path_is_the_same_code() -> None:
    assert (edge_geo.offset, edge_geo.distance_m, edge_geo.bearing_deg) == (
        geo.offset,
        geo.distance_m,
        geo.bearing_deg,
    )  # one implementation, not a copy to keep in step
