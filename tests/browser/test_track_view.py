"""The track view in a real browser: a range of a vessel's track with its reporting gap as a
break, the range changed, a plot hovered (the moment marked on the map), the track clicked
(the nearest fix with every reading and its unit, the moment marked on the plots)."""

from __future__ import annotations

import datetime as dt
import math

import pytest
from django.utils import timezone
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

from telemetry.models import SensorChannel
from telemetry.services import fix_ingest, sensor_channel_save
from tests.browser.support import js, log_in, shot, wait_for
from vessels.models import Vessel
from vessels.services import vessel_save

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]

HOURS = 30
GAP = (5, 3)  # hours ago: the boat was silent from 5 h to 3 h ago


@pytest.fixture
def voyage(vessel_a: Vessel) -> Vessel:
    """A fix a minute (its period) for 30 hours on a slow circle, with a two-hour gap."""
    vessel_a.telemetry_period_s = 60
    vessel_save(vessel=vessel_a)
    sensor_channel_save(
        channel=SensorChannel(key="water_temp_c", label="Water temperature", unit="°C")
    )
    now = timezone.now().replace(second=0, microsecond=0)
    records = []
    for minute in range(HOURS * 60):
        t = now - dt.timedelta(minutes=minute)
        if GAP[1] * 60 < minute < GAP[0] * 60:
            continue
        a = minute / 240
        records.append(
            {
                "time": t.isoformat(),
                "lat": -31.98 + 0.01 * math.sin(a),
                "lon": 115.82 + 0.012 * math.cos(a),
                "heading_deg": (math.degrees(a) + 90) % 360,
                "speed_mps": 1.5,
                "battery_v": 12.0 + 0.8 * math.cos(minute / 300),
                "readings": {"water_temp_c": 19 + math.sin(minute / 90), "salinity_psu": 35.2},
            }
        )
    fix_ingest(vessel=vessel_a, records=records)
    return vessel_a


def plot_keys(browser) -> list[str]:
    return [
        p.get_attribute("data-key") for p in browser.find_elements(By.CSS_SELECTOR, "#plots .plot")
    ]


def summary(browser) -> str:
    return browser.find_element(By.ID, "track-summary").text


def test_an_operator_reads_a_track_changes_its_range_and_links_plots_and_map(
    browser, live_server, operator_user, voyage: Vessel
) -> None:
    log_in(browser, live_server, operator_user)
    browser.get(live_server.url + f"/fleet/vessels/{voyage.slug}/track/")
    wait_for(browser, lambda b: "fixes in range" in summary(b) and len(plot_keys(b)) == 3)
    assert plot_keys(browser) == ["battery_v", "salinity_psu", "water_temp_c"]
    titles = [t.text for t in browser.find_elements(By.CSS_SELECTOR, "#plots .plot-title")]
    assert titles[0] == "Battery (V)" and "Water temperature (°C)" in titles
    assert "salinity_psu" in titles  # a reading with no channel still plots, under its key
    assert "2 stretches" in summary(browser)  # the gap is a break, not a straight jump
    day = summary(browser)
    shot(browser, "track-1-24h")

    browser.find_element(By.CSS_SELECTOR, '[data-range="6h"]').click()
    wait_for(browser, lambda b: "range=6h" in b.current_url and summary(b) != day)
    wait_for(browser, lambda b: "fixes in range" in summary(b))
    assert "2 stretches" in summary(browser)
    shot(browser, "track-2-6h")

    js(browser, "document.getElementById('range-from').value = arguments[0];"
       "document.getElementById('range-to').value = arguments[1];",
       (timezone.now() - dt.timedelta(hours=2)).strftime("%Y-%m-%dT%H:%M"),
       (timezone.now() - dt.timedelta(minutes=30)).strftime("%Y-%m-%dT%H:%M"))  # fmt: skip
    browser.find_element(By.ID, "range-apply").click()
    wait_for(browser, lambda b: "from=" in b.current_url and "fixes in range" in summary(b))
    assert "stretches" not in summary(browser)  # after the gap: one stretch
    exports = {
        f: browser.find_element(By.ID, f"export-{f}").get_attribute("href")
        for f in ("csv", "geojson", "gpx")
    }
    assert all(f"format={f}" in url and "from=" in url for f, url in exports.items())

    browser.find_element(By.CSS_SELECTOR, '[data-range="24h"]').click()
    wait_for(browser, lambda b: "range=24h" in b.current_url and "fixes in range" in summary(b))
    wait_for(browser, lambda b: len(plot_keys(b)) == 3)
    # The map and the first plot on one screen, as an operator would have them.
    js(browser, "window.scrollTo(0, document.getElementById('track-summary').offsetTop)")
    over = browser.find_element(By.CSS_SELECTOR, '#plots .plot[data-key="battery_v"] .u-over')
    ActionChains(browser).move_to_element_with_offset(over, -over.size["width"] // 4, 0).perform()
    marker = wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, "#track-map .time-marker"))
    assert marker.get_attribute("data-time")
    shot(browser, "track-3-hover-plot")

    # Click the track at one of its drawn points: the nearest fix, and the plots marked.
    x, y, w, h = js(
        browser,
        "var t = window.shoresideTrack, p = t.points[Math.floor(t.points.length * 0.8)];"
        "var c = t.map.latLngToContainerPoint([p.lat, p.lon]), s = t.map.getSize();"
        "return [c.x, c.y, s.x, s.y]",
    )
    the_map = browser.find_element(By.ID, "track-map")
    ActionChains(browser).move_to_element_with_offset(
        the_map, x - w / 2, y - h / 2
    ).click().perform()
    popup = wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, ".fix-popup"))
    # Leaflet pans the map (animated) until the whole popup is inside it.
    inside = (
        "var p = document.querySelector('.leaflet-popup').getBoundingClientRect(),"
        " m = document.getElementById('track-map').getBoundingClientRect();"
        "return p.top >= m.top && p.bottom <= m.bottom"
    )
    wait_for(browser, lambda b: js(b, inside))
    shot(browser, "track-4-nearest-fix")
    text = popup.get_attribute("textContent")
    for expected in ("Time", "Position", "Speed", "1.5 m/s (2.9 kn)", "Heading", "Battery", " V"):
        assert expected in text
    assert "Water temperature" in text and "°C" in text and "salinity_psu" in text
    assert js(browser, "return window.shoresideTrack.markedT") is not None
    js(browser, "document.getElementById('plots').scrollIntoView()")
    shot(browser, "track-5-plots-marked")
