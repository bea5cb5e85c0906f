"""The track view in a real browser: a range of a vessel's track with its reporting gap as a
break, the range changed, a plot hovered (the moment marked on the map), the track clicked
(the nearest fix with every reading and its unit, the moment marked on the plots)."""

from __future__ import annotations

import datetime as dt
import math

import pytest
from django.utils import timezone
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.actions.action_builder import ActionBuilder
from selenium.webdriver.common.by import By

from edge_client.contract import geo
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
    # It opens on the last run of reports: the three hours since the gap, not 24 h.
    assert "range=last" in browser.current_url and "stretches" not in summary(browser)
    shot(browser, "track-0-last-stretch")

    browser.find_element(By.CSS_SELECTOR, '[data-range="24h"]').click()
    wait_for(browser, lambda b: "range=24h" in b.current_url and "2 stretches" in summary(b))
    # 2 stretches: the gap is a break, not a straight jump
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


# An outing (issue 18 §3): a fix every 5 minutes (the vessel's period) for three hours ending
# two hours ago, east for 90 minutes then north, after 15 silent hours; an older day before.
PERIOD_S = 300
STEP_M = 450.0  # 1.5 m/s for 5 minutes
LEG_STEPS = 18  # 90 minutes a leg
ORIGIN = (-32.05, 115.70)  # off Fremantle


def outing_fixes(end: dt.datetime) -> list[tuple[dt.datetime, float, float]]:
    """(time, lat, lon) of the last stretch: east, then north, one fix per period."""
    fixes, (lat, lon) = [], ORIGIN
    for n in range(2 * LEG_STEPS + 1):
        fixes.append((end - dt.timedelta(seconds=PERIOD_S * (2 * LEG_STEPS - n)), lat, lon))
        lat, lon = geo.offset(lat, lon, 90 if n < LEG_STEPS else 0, STEP_M)
    return fixes


@pytest.fixture
def outing(vessel_a: Vessel) -> tuple[Vessel, list[tuple[dt.datetime, float, float]]]:
    vessel_a.telemetry_period_s = PERIOD_S
    vessel_save(vessel=vessel_a)
    sensor_channel_save(
        channel=SensorChannel(key="water_temp_c", label="Water temperature", unit="°C")
    )
    end = timezone.now().replace(second=0, microsecond=0) - dt.timedelta(hours=2)
    end -= dt.timedelta(minutes=end.minute % 5)
    last = outing_fixes(end)
    older = [
        (end - dt.timedelta(hours=28) + dt.timedelta(seconds=PERIOD_S * n), -32.1, 115.6)
        for n in range(13 * 3600 // PERIOD_S)  # 28 h to 15 h before the end
    ]
    records = [
        {
            "time": t.isoformat(),
            "lat": lat,
            "lon": lon,
            "speed_mps": 1.5,
            "battery_v": 12.0 + 0.01 * n,
            "readings": {
                "water_temp_c": 19 + math.sin(n / 5),
                "mode_number": 10 if n % 37 < 18 else 4,
            },
        }
        for n, (t, lat, lon) in enumerate(older + last)
    ]
    fix_ingest(vessel=vessel_a, records=records)
    return vessel_a, last


def utc_text(when: dt.datetime) -> str:
    return when.astimezone(dt.UTC).strftime("%Y-%m-%d %H:%M")


def open_track(browser, live_server, vessel: Vessel, query: str = "") -> None:
    browser.get(live_server.url + f"/fleet/vessels/{vessel.slug}/track/{query}")
    wait_for(browser, lambda b: "fixes in range" in summary(b) and len(plot_keys(b)) == 3)


def test_the_track_opens_on_its_last_stretch_and_its_times_are_utc_in_a_perth_browser(
    perth_browser, live_server, operator_user, outing
) -> None:
    browser, (vessel, last) = perth_browser, outing
    log_in(browser, live_server, operator_user)
    # The browser's own clock is Perth's, eight hours ahead of UTC.
    assert js(browser, "return new Date().getTimezoneOffset()") == -480
    open_track(browser, live_server, vessel)
    first, newest = last[0][0], last[-1][0]
    # The last three hours of reports, not 24 h (nor the older day before the silence).
    assert "range=last" in browser.current_url
    assert summary(browser).startswith(f"{len(last)} fixes in range")
    assert "stretches" not in summary(browser)
    value = lambda b, i: b.find_element(By.ID, i).get_attribute("value")  # noqa: E731
    assert value(browser, "range-from") == utc_text(first)
    assert value(browser, "range-to") == utc_text(newest + dt.timedelta(minutes=1))
    labels = browser.find_elements(By.CSS_SELECTOR, "#range-bar label")
    assert [label.text for label in labels] == ["from (UTC)", "to (UTC)"]
    shot(browser, "track-6-last-stretch-perth")

    # The times along the track are UTC too, each its own moment, every N minutes, apart.
    ticks = js(
        browser,
        "return Array.from(document.querySelectorAll('#track-map .track-tick')).map(function (n) {"
        " var r = n.firstChild.getBoundingClientRect();"
        " return [n.textContent, +n.dataset.time, r.left, r.top, r.right, r.bottom]; })",
    )
    assert len(ticks) >= 2
    minutes = js(browser, "return window.shoresideTrack.trackLayer.getLayers()"
                 ".filter(function (l) { return l.minutes; })[0].minutes")  # fmt: skip
    for text, t, *_ in ticks:
        when = dt.datetime.fromtimestamp(t, dt.UTC)
        assert text == when.strftime("%H:%M") and t % (minutes * 60) == 0
        assert first.timestamp() <= t <= newest.timestamp()
    for i, a in enumerate(ticks):
        for b in ticks[i + 1 :]:
            apart = a[4] <= b[2] or b[4] <= a[2] or a[5] <= b[3] or b[5] <= a[3]
            assert apart, f"time labels {a[0]} and {b[0]} overlap"

    # The plots' legend and the map's moment marker say UTC times too.
    over = browser.find_element(By.CSS_SELECTOR, '#plots .plot[data-key="battery_v"] .u-over')
    ActionChains(browser).move_to_element_with_offset(over, 0, 0).perform()
    marker = wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, "#track-map .time-marker"))
    bucket, moment = js(
        browser,
        "var u = window.shoresideTrack.plots[0];"
        " return [u.data[0][u.cursor.idx], u.posToVal(u.cursor.left, 'x')]",
    )
    legend = browser.find_element(
        By.CSS_SELECTOR, "#plots .u-legend .u-series:first-child .u-value"
    )
    assert legend.text == f"{dt.datetime.fromtimestamp(bucket, dt.UTC):%Y-%m-%d %H:%M:%S} UTC"
    label = marker.get_attribute("textContent")
    assert label == f"{dt.datetime.fromtimestamp(int(moment), dt.UTC):%H:%M:%S}"

    # Typed in UTC, taken as UTC: an hour in the middle of the stretch holds 12 fixes.
    start, end = newest - dt.timedelta(hours=2), newest - dt.timedelta(hours=1)
    for field, when in (("range-from", start), ("range-to", end)):
        box = browser.find_element(By.ID, field)
        box.clear()
        box.send_keys(utc_text(when))
    browser.find_element(By.ID, "range-apply").click()
    wait_for(browser, lambda b: "from=" in b.current_url and "fixes in range" in summary(b))
    assert f"from={start.astimezone(dt.UTC):%Y-%m-%dT%H:%M:%S}Z" in browser.current_url
    assert f"to={end.astimezone(dt.UTC):%Y-%m-%dT%H:%M:%S}Z" in browser.current_url
    assert summary(browser).startswith("12 fixes in range")
    assert value(browser, "range-from") == utc_text(start)

    box = browser.find_element(By.ID, "range-from")
    box.clear()
    box.send_keys("2026-02-30 10:00")  # no such day
    browser.find_element(By.ID, "range-apply").click()
    assert "UTC" in summary(browser) and "errornote" in browser.find_element(
        By.ID, "track-summary"
    ).get_attribute("class")


def click_at(browser, x: float, y: float) -> None:
    """A click at (x, y) in the window, to the pixel (an element's offsets are rounded)."""
    actions = ActionBuilder(browser)
    actions.pointer_action.move_to_location(round(x), round(y)).click()
    actions.perform()


def plot_geometry(browser) -> list[list[float]]:
    return js(
        browser,
        "return Array.from(document.querySelectorAll('#plots .u-over')).map(function (o) {"
        " var r = o.getBoundingClientRect(); return [r.left, r.width]; })",
    )


def test_plots_share_aligned_axes_and_one_cursor_and_a_click_near_the_track_picks_a_fix(
    browser, live_server, operator_user, outing
) -> None:
    vessel, last = outing
    log_in(browser, live_server, operator_user)
    open_track(browser, live_server, vessel)
    assert plot_keys(browser) == ["battery_v", "mode_number", "water_temp_c"]
    # The mode's axis names its states (wider than the battery's numbers): all plots still
    # start and end at the same x, so their time axes line up.
    geometry = plot_geometry(browser)
    assert len(geometry) == 3 and all(g == pytest.approx(geometry[0], abs=0.5) for g in geometry)

    # Arrows point the way the vessel went: east on the first leg, then north.
    bearings = [
        float(a.get_attribute("data-bearing"))
        for a in browser.find_elements(By.CSS_SELECTOR, "#track-map .track-arrow")
    ]
    assert len(bearings) >= 4
    east = [b for b in bearings if abs(b - 90) < 5]
    north = [b for b in bearings if min(b, 360 - b) < 5]
    assert east and north and len(east) + len(north) == len(bearings)

    # One cursor: hovering the mode plot moves the cursor on all three to the same moment,
    # and the map marks where the vessel was then.
    js(browser, "window.scrollTo(0, document.getElementById('track-summary').offsetTop)")
    over = browser.find_element(By.CSS_SELECTOR, '#plots .plot[data-key="mode_number"] .u-over')
    ActionChains(browser).move_to_element_with_offset(over, over.size["width"] // 5, 0).perform()
    marker = wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, "#track-map .time-marker"))
    cursors = js(
        browser,
        "return window.shoresideTrack.plots.map(function (u) {"
        " return [u.cursor.left, u.posToVal(u.cursor.left, 'x')]; })",
    )
    assert cursors[0][0] > 0
    assert all(c == pytest.approx(cursors[0], abs=0.5) for c in cursors)
    legends = [
        e.text
        for e in browser.find_elements(
            By.CSS_SELECTOR, "#plots .u-legend .u-series:first-child .u-value"
        )
    ]
    assert len(legends) == 3 and len(set(legends)) == 1 and legends[0].endswith("UTC")
    assert float(marker.get_attribute("data-time")) == pytest.approx(cursors[0][1], abs=1)
    shot(browser, "track-7-shared-cursor")

    # A click 7 px beside the track, off the fix at 30 minutes into the outing, picks that
    # fix; one 25 px away picks nothing.
    when, lat, lon = last[6]
    js(browser, "window.scrollTo(0, document.getElementById('track-summary').offsetTop)")
    x, y = js(
        browser,
        "var m = window.shoresideTrack.map, box = m.getContainer(),"
        " c = m.latLngToContainerPoint([arguments[0], arguments[1]]),"
        " r = box.getBoundingClientRect();"
        " return [r.left + box.clientLeft + c.x, r.top + box.clientTop + c.y]",
        lat,
        lon,
    )
    click_at(browser, x, y - 25)
    assert js(browser, "return window.shoresideTrack.markedT") is None
    assert not browser.find_elements(By.CSS_SELECTOR, ".fix-popup")
    click_at(browser, x, y - 7)
    popup = wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, ".fix-popup"))
    # textContent: the popup fades in, and a transparent element has no .text for selenium.
    assert f"{when.astimezone(dt.UTC):%Y-%m-%d %H:%M:%S} UTC" in popup.get_attribute("textContent")
    # The moment is marked on the plots and every cursor moves to it.
    wait_for(browser, lambda b: js(b, "return window.shoresideTrack.markedT") == when.timestamp())
    at = js(
        browser,
        "var t = arguments[0]; return window.shoresideTrack.plots.map(function (u) {"
        " return Math.abs(u.cursor.left - u.valToPos(t, 'x')); })",
        when.timestamp(),
    )
    assert all(d < 1 for d in at), at
    opaque = "return getComputedStyle(document.querySelector('.leaflet-popup')).opacity === '1'"
    wait_for(browser, lambda b: js(b, opaque))  # faded in, for the screenshot
    shot(browser, "track-8-click-near-track")
    js(browser, "document.getElementById('plots').scrollIntoView()")
    shot(browser, "track-9-aligned-plots-marked")
