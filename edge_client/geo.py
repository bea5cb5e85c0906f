"""The old path of the geometry, kept for code written against it: see edge_client.contract.geo."""

from edge_client.contract.geo import EARTH_RADIUS_M, bearing_deg, distance_m, offset

__all__ = ["EARTH_RADIUS_M", "bearing_deg", "distance_m", "offset"]
