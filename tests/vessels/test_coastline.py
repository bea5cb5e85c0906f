"""The offline coastline's build (vessels/coastline.py, manage.py build_coastline) and the
files it made (issue 18 §1): quantisation, clipping into cells without losing land, the
antimeridian, and the vendored Natural Earth cells off Fremantle."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import pytest
from django.contrib.auth.models import User
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.fleet.test_pages import client_for, page_config
from vessels import coastline as c
from vessels.management.commands.build_coastline import OUT, Command

ROTTNEST = (115.50, -32.00)  # lon, lat
SEA_OFF_FREMANTLE = (115.62, -32.03)


def area(poly: c.Polygon) -> float:
    return abs(c.twice_area(poly[0])) / 2 - sum(abs(c.twice_area(h)) / 2 for h in poly[1:])


def inside(point: tuple[float, float], ring: list) -> bool:
    """Even-odd ray casting."""
    x, y, hit = point[0], point[1], False
    for (x1, y1), (x2, y2) in zip(ring, ring[1:] + ring[:1], strict=True):
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            hit = not hit
    return hit


def decoded_rings(topology: dict) -> list[list[list[c.Point]]]:
    """The land's polygons of a cell topology, in degrees, as the browser decodes them."""
    arcs = c.decode_arcs(topology)
    return [[c.stitch(arcs, r) for r in poly] for poly in topology["objects"]["land"]["arcs"]]


# --- quantisation ---------------------------------------------------------------------------


@given(st.floats(0, 1), st.integers(1, 1 << 16), st.floats(-180, 175))
def test_quantising_moves_a_point_half_a_step_at_most_and_keeps_it_in_the_cell(
    f: float, q: int, origin: float
) -> None:
    step = 5 / q
    value = origin + f * 5
    k = c.quantise(value, origin, step, q)
    assert 0 <= k <= q
    assert abs(origin + k * step - value) <= step / 2 + 1e-9


def test_the_cell_edges_quantise_to_0_and_q_and_outside_is_held_to_them() -> None:
    assert c.quantise(115.0, 115.0, 5 / 8192, 8192) == 0
    assert c.quantise(120.0, 115.0, 5 / 8192, 8192) == 8192
    assert c.quantise(121.0, 115.0, 5 / 8192, 8192) == 8192
    assert c.quantise(114.0, 115.0, 5 / 8192, 8192) == 0


def test_delta_encoding_is_toposjons() -> None:
    assert c.delta([(3, 4), (5, 4), (5, 1)]) == [[3, 4], [2, 0], [0, -3]]


# --- clipping into cells --------------------------------------------------------------------


@st.composite
def star_polygons(draw: st.DrawFn) -> c.Polygon:
    """A simple polygon (concave as often as not): points round a centre at rising angles, the
    centre itself a corner where they leave a gap of half a turn or more."""
    cx, cy = draw(st.floats(-30, 30)), draw(st.floats(-30, 30))
    n = draw(st.integers(3, 12))
    angles = sorted(
        draw(
            st.lists(
                st.floats(0, 2 * math.pi, exclude_max=True), min_size=n, max_size=n, unique=True
            )
        )
    )
    radii = draw(st.lists(st.floats(0.2, 14), min_size=n, max_size=n))
    ring = [
        (cx + r * math.cos(a), cy + r * math.sin(a)) for a, r in zip(angles, radii, strict=True)
    ]
    gaps = [(angles[i] - angles[i - 1]) % (2 * math.pi) or 2 * math.pi for i in range(n)]
    widest = max(range(n), key=gaps.__getitem__)
    if gaps[widest] >= math.pi:
        ring.insert(widest, (cx, cy))
    if abs(c.twice_area(ring)) < 1e-3:
        ring = [(cx - 1, cy - 1), (cx + 1, cy - 1), (cx, cy + 1)]
    return [ring]


@settings(max_examples=200, deadline=None)
@given(star_polygons(), st.sampled_from([5, 10]))
def test_cutting_into_cells_keeps_all_the_land_and_every_cell_it_reaches(
    poly: c.Polygon, size: int
) -> None:
    pieces = list(c.pieces(poly, size))
    # No land lost or made: the pieces' areas add up to the polygon's.
    assert sum(area(p) for _, p in pieces) == pytest.approx(area(poly), rel=1e-6, abs=1e-6)
    by_cell = {cell: piece for cell, piece in pieces}
    assert len(by_cell) == len(pieces)  # one piece a cell (a polygon's part there)
    for cell, piece in pieces:
        for lon, lat in piece[0]:
            assert cell.west - 1e-9 <= lon <= cell.east + 1e-9
            assert cell.south - 1e-9 <= lat <= cell.north + 1e-9
    # Every cell the polygon covers some of has a piece of it, that part: each cell of the
    # polygon's box clipped on its own (no rows first, no cells skipped) says the same.
    box = c.bbox(poly[0])
    for lat in range(math.floor(box.south / size) * size, math.ceil(box.north), size):
        for lon in range(math.floor(box.west / size) * size, math.ceil(box.east), size):
            cell = c.Cell(lon, lat, lon + size, lat + size)
            alone = c.clip_polygon(poly, cell)
            if alone and area(alone) > 1e-9:
                assert area(by_cell[cell]) == pytest.approx(area(alone), rel=1e-6, abs=1e-9)
    # And after quantising, every cell with land of some size is in the split.
    split = c.split([poly], size, 8192)
    for cell, piece in pieces:
        if area(piece) > 0.05:
            assert cell in split


@settings(max_examples=100, deadline=None)
@given(star_polygons())
def test_the_coastline_has_no_edge_on_a_cells_border_and_the_land_decodes_back(
    poly: c.Polygon,
) -> None:
    q = 4096
    for cell, topology in c.split([poly], 5, q).items():
        arcs = topology["arcs"]
        ints = []
        for arc in arcs:
            x = y = 0
            points = []
            for dx, dy in arc:
                x, y = x + dx, y + dy
                points.append((x, y))
            ints.append(points)
        for (index,) in topology["objects"]["coastline"]["arcs"]:
            line = ints[index]
            assert not any(c.on_border(a, b, q) for a, b in zip(line, line[1:], strict=False))
        for rings in topology["objects"]["land"]["arcs"]:
            for ring in rings:
                stitched = c.stitch(ints, ring)
                assert stitched[0] == stitched[-1]  # each ring closes
                assert all(0 <= x <= q and 0 <= y <= q for x, y in stitched)
        # The land drawn from the cell is the polygon's part there, to a grid step.
        drawn = sum(area([c.open_ring(r) for r in p]) for p in decoded_rings(topology))
        exact = area(c.clip_polygon(poly, cell))
        assert drawn == pytest.approx(exact, abs=len(poly[0]) * 4 * (5 / q) * 5)


def test_a_polygon_across_the_antimeridian_is_cut_there_not_drawn_round_the_world() -> None:
    fiji = [[(179.0, -17.0), (-179.0, -17.0), (-179.0, -16.0), (179.0, -16.0)]]
    world = c.split([fiji], None, 36000)[c.WORLD]
    polys = decoded_rings(world)
    assert len(polys) == 2  # one each side of ±180°
    for poly in polys:
        box = c.bbox(poly[0])
        assert box.east - box.west == pytest.approx(1.0, abs=0.02)
    cells = c.split([fiji], 5, 8192)
    assert sorted(cell.name for cell in cells) == ["s20e175", "s20w180"]


def test_a_ring_round_the_pole_is_closed_along_it() -> None:
    # Antarctica as Natural Earth has it: round the pole, crossing ±180° once.
    ring = [(lon, -70.0) for lon in range(-180, 180, 30)]
    unwrapped = c.unwrap(ring)
    assert unwrapped[-2:] == [(180.0, -90.0), (-180.0, -90.0)]
    pieces = list(c.pieces([ring], None))
    assert len(pieces) == 1
    assert area(pieces[0][1]) == pytest.approx(360 * 20)  # everything south of 70°S


# --- the build command and the files it made ------------------------------------------------


def test_the_build_writes_a_folder_named_after_its_files_and_an_index(tmp_path: Path) -> None:
    (tmp_path / "old").mkdir()
    cells = c.split([[[(115.4, -32.1), (115.6, -32.1), (115.6, -31.9)]]], 5, 8192)
    files = {cell.name: json.dumps(t).encode() for cell, t in cells.items()}
    Command().write(tmp_path, [("10m", 5, 6, files)])
    index = json.loads((tmp_path / "index.json").read_text())
    version = index["base"].rstrip("/")
    assert not (tmp_path / "old").exists()  # a rebuild leaves no stale cells
    assert index["levels"] == [{"name": "10m", "minzoom": 6, "cell": 5, "cells": ["s35e115"]}]
    assert (tmp_path / version / "10m" / "s35e115.json").read_bytes() == files["s35e115"]
    assert len(version) == 12 and int(version, 16) >= 0
    Command().write(tmp_path, [("10m", 5, 6, files)])
    assert json.loads((tmp_path / "index.json").read_text())["base"] == index["base"]  # same


def vendored() -> dict:
    return json.loads((OUT / "index.json").read_text())


def test_the_vendored_index_lists_the_files_there_and_nothing_else() -> None:
    index = vendored()
    base = OUT / index["base"]
    listed = {f"{lvl['name']}/{cell}.json" for lvl in index["levels"] for cell in lvl["cells"]}
    on_disk = {str(p.relative_to(base)) for p in base.rglob("*.json")}
    assert listed == on_disk
    assert [lvl["name"] for lvl in index["levels"]] == ["110m", "50m", "10m"]
    # The folder's name is the hash of its files: edited by hand, it would not match.
    digest = hashlib.sha256()
    for lvl in index["levels"]:
        for cell in sorted(lvl["cells"]):
            body = (base / lvl["name"] / f"{cell}.json").read_bytes()
            digest.update(f"{lvl['name']}/{cell}:{len(body)}:".encode() + body)
    assert digest.hexdigest()[:12] == index["base"].rstrip("/")
    assert (OUT / "LICENSE").exists() and (OUT / "README.md").exists()


def test_the_vendored_1_10m_cell_off_fremantle_has_rottnest_as_land_and_the_sound_as_sea() -> None:
    index = vendored()
    cell = json.loads((OUT / index["base"] / "10m" / "s35e115.json").read_text())
    polys = decoded_rings(cell)
    assert any(inside(ROTTNEST, p[0]) for p in polys)
    assert not any(inside(SEA_OFF_FREMANTLE, p[0]) for p in polys)
    # Rottnest is an island of its own: a small polygon, about 11 km by 3.
    rottnest = [p for p in polys if inside(ROTTNEST, p[0])][0]
    box = c.bbox(rottnest[0])
    assert 0.05 < box.east - box.west < 0.2 and 0.01 < box.north - box.south < 0.06


@pytest.mark.django_db
def test_every_map_page_carries_the_coastline_index_and_it_is_served(
    operator_user: User,
) -> None:
    client = client_for(operator_user)
    html = client.get("/admin/").content.decode()
    url = page_config(html, "map-config")["coastline"]
    assert url.endswith("vessels/vendor/naturalearth/index.json")
    response = client.get(url)
    assert response.status_code == 200
    index = json.loads(b"".join(response.streaming_content))
    cell = f"{url.rsplit('/', 1)[0]}/{index['base']}10m/s35e115.json"
    assert client.get(cell).status_code == 200
