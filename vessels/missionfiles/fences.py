"""Fences read from files (pure): a QGroundControl `.plan`'s `geoFence` section, or GeoJSON.

QGC (dev guide, file_formats/plan, "GeoFence"): ``geoFence`` holds ``polygons``, each
``{"polygon": [[lat, lon], …], "inclusion": bool}`` with the ring left open, and ``circles``,
each ``{"circle": {"center": [lat, lon], "radius": metres}, "inclusion": bool}``. QGC writes
them for ArduPilot Rover as its fence items (inclusion and exclusion polygons and circles).

GeoJSON (RFC 7946): a FeatureCollection, one Feature or a bare geometry; each Polygon (or each
polygon of a MultiPolygon) is a fence, and a Point with ``properties.radius_m`` is a circle.
``properties.inclusion`` (default true) and ``properties.name`` are read when present.
Coordinates are [longitude, latitude]; the fence's own checks are vessels.fences.clean.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vessels import fences
from vessels.errors import VesselsError
from vessels.missionfiles.model import checked_text, load_json

# More fences than any autopilot stores in one file is not a fence file (a coastline dataset).
MAX_FENCES = 50


class FenceFileError(VesselsError):
    """A fence file that cannot be read, or holds a fence that cannot be stored."""

    field = "file"


@dataclass(frozen=True)
class FenceSpec:
    """One fence read from a file, checked (vessels.fences.clean)."""

    inclusion: bool
    geometry: dict[str, Any]
    radius_m: float | None = None
    name: str = ""


def load(content: bytes | str, *, format: str | None = None) -> list[FenceSpec]:
    """Every fence in the file, or a FenceFileError listing each problem by where it is.

    ``format`` is "plan" or "geojson"; by default a JSON object with ``"fileType"`` is a plan.
    """
    try:
        data = load_json(content, "fence")
    except VesselsError as exc:
        raise FenceFileError(exc.message) from None
    if not isinstance(data, dict):
        raise FenceFileError("not a fence file: expected a JSON object")
    if format is None:
        format = "plan" if "fileType" in data else "geojson"
    if format == "plan":
        found, errors = _from_plan(data)
    elif format == "geojson":
        found, errors = _from_geojson(data)
    else:
        raise FenceFileError(f"format must be plan or geojson (got {format!r:.20})")
    if errors:
        raise FenceFileError(errors[0], problems=errors)
    if not found:
        raise FenceFileError("the file holds no fence (no polygon or circle)")
    if len(found) > MAX_FENCES:
        raise FenceFileError(f"the file holds {len(found)} fences; at most {MAX_FENCES} at once")
    return found


def _inclusion(where: str, value: Any) -> bool:
    if value is None:
        return True
    if not isinstance(value, bool):
        raise FenceFileError(f"{where}: inclusion must be true or false (got {value!r:.20})")
    return value


def _checked(where: str, geometry: Any, radius_m: Any = None) -> tuple[dict[str, Any], Any]:
    try:
        return fences.clean(geometry, radius_m)
    except VesselsError as exc:
        raise FenceFileError(f"{where}: {exc.message}") from None


def _latlon_ring(where: str, value: Any) -> list[list[Any]]:
    """QGC's open ring of [lat, lon] as a closed GeoJSON ring of [lon, lat]."""
    if not isinstance(value, list) or not all(isinstance(p, list) and len(p) >= 2 for p in value):
        raise FenceFileError(f"{where}: polygon must be a list of [latitude, longitude]")
    ring = [[p[1], p[0]] for p in value]
    if ring and ring[0] != ring[-1]:
        ring.append(ring[0])
    return ring


def _from_plan(plan: dict[str, Any]) -> tuple[list[FenceSpec], list[str]]:
    if plan.get("fileType") != "Plan":
        raise FenceFileError('not a QGroundControl plan: no "fileType": "Plan"')
    section = plan.get("geoFence")
    if not isinstance(section, dict):
        raise FenceFileError('the plan has no "geoFence" section')
    polygons, circles = section.get("polygons") or [], section.get("circles") or []
    if not isinstance(polygons, list) or not isinstance(circles, list):
        raise FenceFileError("geoFence: polygons and circles must be lists")
    found: list[FenceSpec] = []
    errors: list[str] = []
    for n, entry in enumerate(polygons, start=1):
        where = f"geoFence polygon {n}"
        try:
            if not isinstance(entry, dict):
                raise FenceFileError(f"{where} is not an object")
            ring = _latlon_ring(where, entry.get("polygon"))
            geometry, _ = _checked(where, {"type": "Polygon", "coordinates": [ring]})
            found.append(FenceSpec(_inclusion(where, entry.get("inclusion")), geometry))
        except VesselsError as exc:
            errors.extend(exc.problems)
    for n, entry in enumerate(circles, start=1):
        where = f"geoFence circle {n}"
        try:
            circle = entry.get("circle") if isinstance(entry, dict) else None
            if not isinstance(circle, dict):
                raise FenceFileError(f"{where}: no circle with a center and radius")
            centre = circle.get("center")
            if not isinstance(centre, list) or len(centre) < 2:
                raise FenceFileError(f"{where}: center must be [latitude, longitude]")
            point = {"type": "Point", "coordinates": [centre[1], centre[0]]}
            geometry, radius = _checked(where, point, circle.get("radius"))
            found.append(FenceSpec(_inclusion(where, entry.get("inclusion")), geometry, radius))
        except VesselsError as exc:
            errors.extend(exc.problems)
    return found, errors


def _features(data: dict[str, Any]) -> list[Any]:
    kind = data.get("type")
    if kind == "FeatureCollection":
        if not isinstance(data.get("features"), list):
            raise FenceFileError("not GeoJSON: a FeatureCollection needs a list of features")
        return data["features"]
    if kind == "Feature":
        return [data]
    if isinstance(kind, str):
        return [{"type": "Feature", "geometry": data, "properties": {}}]
    raise FenceFileError('not GeoJSON: expected an object with a "type"')


def _name(where: str, props: dict[str, Any]) -> str:
    name = props.get("name")
    return checked_text(f"{where}: name", name)[:100] if isinstance(name, str) else ""


def _from_feature(where: str, feature: Any) -> list[FenceSpec]:
    if not isinstance(feature, dict) or not isinstance(feature.get("geometry"), dict):
        raise FenceFileError(f"{where}: a Feature with a geometry is expected")
    geometry = feature["geometry"]
    props = feature.get("properties") if isinstance(feature.get("properties"), dict) else {}
    inclusion, name = _inclusion(where, props.get("inclusion")), _name(where, props)
    kind = geometry.get("type")
    if kind == "MultiPolygon":
        parts = geometry.get("coordinates")
        if not isinstance(parts, list):
            raise FenceFileError(f"{where}: a MultiPolygon's coordinates are a list of polygons")
        return [
            FenceSpec(
                inclusion,
                _checked(f"{where}, polygon {m}", {"type": "Polygon", "coordinates": part})[0],
                name=f"{name} {m}" if name else "",
            )
            for m, part in enumerate(parts, start=1)
        ]
    if kind == "Point":
        radius = props.get("radius_m", props.get("radius"))
        checked, radius = _checked(where, geometry, radius)
        return [FenceSpec(inclusion, checked, radius, name)]
    if kind == "Polygon":
        return [FenceSpec(inclusion, _checked(where, geometry)[0], name=name)]
    kind = checked_text(f"{where}: type", kind)[:40] if isinstance(kind, str) else kind
    raise FenceFileError(f"{where}: a {kind} is no fence (Polygon, or Point with radius_m)")


def _from_geojson(data: dict[str, Any]) -> tuple[list[FenceSpec], list[str]]:
    found: list[FenceSpec] = []
    errors: list[str] = []
    for n, feature in enumerate(_features(data), start=1):
        try:
            found.extend(_from_feature(f"feature {n}", feature))
        except VesselsError as exc:
            errors.extend(exc.problems)
    return found, errors
