"""The offline coastline in a real browser (issue 18 §1): with no tile server the fleet map
draws Natural Earth land off Fremantle, Rottnest Island and all, from local files only; with a
tile server that fails it says so, drops the tile layer and draws the coastline instead."""

from __future__ import annotations

from urllib.parse import urlsplit

import pytest
from selenium.webdriver.common.by import By

from tests.browser.support import js, log_in, set_view, shot, wait_for

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]

ROTTNEST = (-32.00, 115.50)
OFF_FREMANTLE = (-32.03, 115.62)  # Rottnest to the west, the coast to the east
BASE = "window.Shoreside.maps['fleet-map']"


def coastline_loaded(browser) -> list[str]:
    return js(browser, f"return {BASE}.coastline.loaded.slice()")


def requested(browser) -> list[str]:
    return js(browser, "return performance.getEntriesByType('resource').map(e => e.name)")


def open_fleet_map(browser, live_server, user) -> None:
    log_in(browser, live_server, user)
    wait_for(browser, lambda b: js(b, f"return !!(window.Shoreside.maps && {BASE})"))


def test_with_no_tiles_the_fleet_map_draws_the_coast_and_rottnest_from_local_files(
    browser, live_server, operator_user
) -> None:
    open_fleet_map(browser, live_server, operator_user)
    set_view(browser, OFF_FREMANTLE, 11, f"{BASE}.map")
    wait_for(browser, lambda b: "10m/s35e115" in coastline_loaded(b))
    # The cell with Rottnest (35°S–30°S, 115°E–120°E) came at the 1:10m detail.
    cells = [u for u in requested(browser) if "/vendor/naturalearth/" in u and "/10m/" in u]
    assert any(u.endswith("/10m/s35e115.json") for u in cells)
    shot(browser, "coastline-1-fremantle-z11")

    pane = "#fleet-map .leaflet-coastline-pane"
    paths = browser.find_elements(By.CSS_SELECTOR, f"{pane} path")
    drawn = [
        p.get_attribute("d") for p in paths if (p.get_attribute("d") or "") not in ("", "M0 0")
    ]
    assert len(drawn) >= 2  # the land's fill and the coast's line
    # Rottnest is land on the map: the point at its middle is inside a land path.
    inside = js(
        browser,
        f"""var m = {BASE}.map, p = m.latLngToContainerPoint([{ROTTNEST[0]}, {ROTTNEST[1]}]);
        var r = m.getContainer().getBoundingClientRect();
        var el = document.elementsFromPoint(r.left + p.x, r.top + p.y);
        return el.some(e => e.tagName === 'path' && e.closest('.leaflet-coastline-pane')
                             && e.getAttribute('fill') !== 'none');""",
    )
    # elementsFromPoint skips pointer-events: none; ask the path itself instead when it does.
    if not inside:
        inside = js(
            browser,
            f"""var m = {BASE}.map, p = m.latLngToLayerPoint([{ROTTNEST[0]}, {ROTTNEST[1]}]);
            var svg = document.querySelector('{pane} svg'), pt = svg.createSVGPoint();
            pt.x = p.x; pt.y = p.y;
            return Array.from(svg.querySelectorAll('path')).some(
                e => e.getAttribute('fill') !== 'none' && e.isPointInFill(pt));""",
        )
    assert inside, "Rottnest's middle is not inside the drawn land"
    # Nor is the sea between Rottnest and the coast.
    sea = js(
        browser,
        f"""var m = {BASE}.map, p = m.latLngToLayerPoint([-32.03, 115.62]);
        var svg = document.querySelector('{pane} svg'), pt = svg.createSVGPoint();
        pt.x = p.x; pt.y = p.y;
        return Array.from(svg.querySelectorAll('path')).some(
            e => e.getAttribute('fill') !== 'none' && e.isPointInFill(pt));""",
    )
    assert sea is False

    attribution = browser.find_element(By.CSS_SELECTOR, "#fleet-map .leaflet-control-attribution")
    assert "Natural Earth" in attribution.text
    assert not browser.find_element(By.CSS_SELECTOR, "#fleet-map .map-banner").is_displayed()
    hosts = {urlsplit(u).hostname for u in requested(browser)}
    assert hosts <= {urlsplit(live_server.url).hostname}

    # Zoomed out, the whole-world levels take over: 1:50m, then 1:110m.
    js(browser, f"{BASE}.map.setZoom(4, {{animate: false}})")
    wait_for(browser, lambda b: "50m/world" in coastline_loaded(b))
    js(browser, f"{BASE}.map.setZoom(1, {{animate: false}})")
    wait_for(browser, lambda b: "110m/world" in coastline_loaded(b))
    shot(browser, "coastline-2-world-z1")
    hosts = {urlsplit(u).hostname for u in requested(browser)}
    assert hosts <= {urlsplit(live_server.url).hostname}


def test_tiles_that_fail_are_dropped_for_the_coastline_with_a_word_on_the_map(
    browser, live_server, operator_user, settings
) -> None:
    settings.MAP_TILES_URL = live_server.url + "/no-tiles-here/{z}/{x}/{y}.png"  # a 404
    settings.MAP_TILES_ATTRIBUTION = "Test tiles"
    open_fleet_map(browser, live_server, operator_user)
    banner = browser.find_element(By.CSS_SELECTOR, "#fleet-map .map-banner")
    wait_for(browser, lambda b: banner.is_displayed())
    assert banner.text == "map tiles unavailable: showing the offline coastline"
    assert js(browser, f"return {BASE}.tiles") is None
    assert not browser.find_elements(By.CSS_SELECTOR, "#fleet-map .leaflet-tile-pane img")
    wait_for(browser, lambda b: len(coastline_loaded(b)) > 0)
    attribution = browser.find_element(By.CSS_SELECTOR, "#fleet-map .leaflet-control-attribution")
    assert "Natural Earth" in attribution.text and "Test tiles" not in attribution.text
    # No more tile requests while the coastline shows.
    tiles_asked = len([u for u in requested(browser) if "/no-tiles-here/" in u])
    js(browser, f"{BASE}.map.panBy([300, 200], {{animate: false}})")
    wait_for(browser, lambda b: js(b, f"return {BASE}.coastline.settled()"))
    assert len([u for u in requested(browser) if "/no-tiles-here/" in u]) == tiles_asked
    shot(browser, "coastline-3-tiles-unavailable")
    # They are tried again in a few minutes.
    wait_s = js(browser, f"return ({BASE}.retryAt - Date.now()) / 1000")
    assert 200 < wait_s <= 300

    # When the retry finds them back (here: any image the server has), they replace the coastline.
    working = live_server.url + "/static/leaflet/images/layers.png?{z}/{x}/{y}"
    js(browser, f"{BASE}.config.tiles_url = '{working}'; {BASE}.tryTiles()")
    wait_for(
        browser, lambda b: b.find_element(By.ID, "fleet-map").get_attribute("data-base") == "tiles"
    )
    assert not banner.is_displayed()
    assert not browser.find_elements(By.CSS_SELECTOR, "#fleet-map .leaflet-coastline-pane path")
    attribution = browser.find_element(By.CSS_SELECTOR, "#fleet-map .leaflet-control-attribution")
    assert "Test tiles" in attribution.text and "Natural Earth" not in attribution.text
