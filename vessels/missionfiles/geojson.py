"""Missions as GeoJSON (RFC 7946), read and written. Pure.

Read: a FeatureCollection (or one Feature, or a bare geometry) whose waypoints are either Point
features, with optional properties ``seq``, ``hold_s``, ``radius_m``, ``speed_mps``, or one
LineString (its vertices, with default hold and radius). A Point with ``"role": "home"`` is the
planned home; a LineString with ``"role": "route"`` beside Points is the drawn route (what this
module writes for map viewers) and is not read. The collection's ``properties`` (a foreign
member, RFC 7946 §6.1) may carry the mission's ``name`` and ``end``. Coordinates are
[longitude, latitude] (RFC 7946 §3.1.1).
"""

from __future__ import annotations

import json
from typing import Any

from vessels.errors import MissionFileError
from vessels.missionfiles.model import (
    Item,
    MissionFile,
    checked_text,
    finish,
    finite,
    hold,
    load_json,
    position,
    radius,
    speed,
)
from vessels.missions import ENDS

CONTENT_TYPE = "application/geo+json"
EXTENSION = "geojson"


def load(content: bytes | str, *, skip_unsupported: bool = False, name: str = "") -> MissionFile:
    data = load_json(content, "GeoJSON")
    features, props = _features(data)
    name = name or _name(props)
    end = props.get("end", "stop")
    if end not in ENDS:
        raise MissionFileError(f"properties.end must be one of {', '.join(ENDS)} (got {end!r})")
    points: list[tuple[Any, int, dict[str, Any]]] = []
    lines: list[tuple[int, list[Any]]] = []
    home, errors, unsupported = None, [], []
    for n, feature in enumerate(features, start=1):
        where = f"feature {n}"
        try:
            geometry, fprops = _geometry(where, feature)
            kind = geometry.get("type")
            if kind == "Point" and fprops.get("role") == "home":
                home = _lat_lon(f"{where} (home)", geometry.get("coordinates"))
            elif kind == "Point":
                fprops["_position"] = _lat_lon(where, geometry.get("coordinates"))
                points.append((fprops.get("seq"), n, fprops))
            elif kind == "LineString" and fprops.get("role") != "route":
                coords = geometry.get("coordinates")
                if not isinstance(coords, list):
                    raise MissionFileError(f"{where}: a LineString needs a list of coordinates")
                lines.append((n, coords))
            elif kind != "LineString":
                kind = (
                    checked_text(f"{where}: geometry type", kind) if isinstance(kind, str) else kind
                )
                unsupported.append(f"{where} ({kind}): a mission is Points or one LineString")
        except MissionFileError as exc:
            errors.extend(exc.problems)
    items: list[Item] = []
    if points:
        items = _from_points(points, errors)
        unsupported += [f"feature {n} (LineString): the waypoints are the Points" for n, _ in lines]
    elif lines:
        (n, coords), *extra = lines
        items = _from_line(n, coords, errors)
        unsupported += [f"feature {m} (LineString): only one LineString is read" for m, _ in extra]
    return finish(
        items,
        end=end,
        home=home,
        name=name,
        errors=errors,
        unsupported=unsupported,
        skip_unsupported=skip_unsupported,
    )


def _features(data: Any) -> tuple[list[Any], dict[str, Any]]:
    if not isinstance(data, dict) or not isinstance(data.get("type"), str):
        raise MissionFileError('not GeoJSON: expected an object with a "type"')
    props = data.get("properties") if isinstance(data.get("properties"), dict) else {}
    if data["type"] == "FeatureCollection":
        if not isinstance(data.get("features"), list):
            raise MissionFileError("not GeoJSON: a FeatureCollection needs a list of features")
        return data["features"], props
    if data["type"] == "Feature":
        return [data], props
    return [{"type": "Feature", "geometry": data, "properties": {}}], {}


def _name(props: dict[str, Any]) -> str:
    name = props.get("name", "")
    return checked_text("properties.name", name) if isinstance(name, str) else ""


def _geometry(where: str, feature: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    if not isinstance(feature, dict) or not isinstance(feature.get("geometry"), dict):
        raise MissionFileError(f"{where}: a Feature with a geometry is expected")
    props = feature.get("properties")
    return feature["geometry"], dict(props) if isinstance(props, dict) else {}


def _lat_lon(where: str, coords: Any) -> tuple[float, float]:
    if not isinstance(coords, list) or len(coords) < 2:
        raise MissionFileError(f"{where}: coordinates must be [longitude, latitude]")
    return position(where, coords[1], coords[0])


def _from_points(points: list[tuple[Any, int, dict[str, Any]]], errors: list[str]) -> list[Item]:
    # By seq when every point has one (a GIS tool may reorder features), else in file order.
    if all(finite(seq) for seq, _n, _p in points):
        points = sorted(points, key=lambda p: (p[0], p[1]))
    items = []
    for _seq, n, props in points:
        where = f"feature {n}"
        try:
            lat, lon = props["_position"]
            change = props.get("speed_mps")
            items.append(
                Item(
                    lat,
                    lon,
                    hold(where, props.get("hold_s")),
                    radius(where, props.get("radius_m")),
                    None if change is None else speed(where, change),
                )
            )
        except MissionFileError as exc:
            errors.extend(exc.problems)
    return items


def _from_line(n: int, coords: list[Any], errors: list[str]) -> list[Item]:
    items = []
    for v, vertex in enumerate(coords, start=1):
        try:
            items.append(Item(*_lat_lon(f"feature {n}, vertex {v}", vertex)))
        except MissionFileError as exc:
            errors.extend(exc.problems)
    return items


def dump(mission: MissionFile) -> str:
    features: list[dict[str, Any]] = []
    if mission.home is not None:
        features.append(_point(mission.home, {"role": "home"}))
    for seq, item in enumerate(mission.items, start=1):
        props = {"seq": seq, **item.as_dict()}
        del props["lat"], props["lon"]
        features.append(_point((item.lat, item.lon), props))
    features.append(
        {
            "type": "Feature",
            "geometry": {
                "type": "LineString",
                "coordinates": [[item.lon, item.lat] for item in mission.items],
            },
            "properties": {"role": "route"},
        }
    )
    collection = {
        "type": "FeatureCollection",
        "properties": {"name": mission.name, "end": mission.end},
        "features": features,
    }
    return json.dumps(collection, indent=2, allow_nan=False) + "\n"


def _point(where: tuple[float, float], props: dict[str, Any]) -> dict[str, Any]:
    return {
        "type": "Feature",
        "geometry": {"type": "Point", "coordinates": [where[1], where[0]]},
        "properties": props,
    }
