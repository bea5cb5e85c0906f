"""One display format in a real browser: the pages' formatters (mapkit.js) write what the
server's (vessels.display) write; the fleet map panel and the track name the autopilot's mode
and armed state and plot them as steps; the fixes list fits a 1400 px window."""

from __future__ import annotations

import datetime as dt
import random
import re

import pytest
from django.utils import timezone
from selenium.webdriver.common.by import By

from commands.models import Command
from commands.services import command_enqueue
from telemetry.models import SensorChannel
from telemetry.services import fix_ingest, sensor_channel_save
from tests.browser.support import js, log_in, shot, wait_for
from vessels.display import (
    fmt_ddm,
    fmt_heading,
    fmt_number,
    fmt_position,
    fmt_speed,
    fmt_time,
    state_channels_config,
)
from vessels.models import Vessel

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]

AUTOPILOT = {"mode_number": 4, "armed": 1, "mission_item": 3}


def test_the_pages_format_as_the_server_does(browser, live_server, operator_user) -> None:
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: js(b, "return !!(window.Shoreside && window.Shoreside.fmtTime)"))
    rng = random.Random(16)
    # Known values, rounding ties and random ones, both hemispheres.
    positions = [(-32.038, 115.3325), (51.5, -0.1275), (10.9999999, -179.9999999), (0.0, 0.0)]
    positions += [(rng.uniform(-90, 90), rng.uniform(-180, 180)) for _ in range(200)]
    speeds = [0.0, 0.25, 1.5, 2.05, 0.75] + [rng.uniform(0, 30) for _ in range(100)]
    numbers = [12.4, 41.0, 1234.56, 0.125, -0.001, 100.05, -2.5] + [
        rng.uniform(-1000, 1000) for _ in range(100)
    ]
    base = dt.datetime(2026, 11, 25, 14, 3, 27, tzinfo=dt.UTC)
    headings = [0.0, 0.5, 89.5, 90.0, 359.4, 359.5] + [rng.uniform(0, 360) for _ in range(50)]
    times = [base + dt.timedelta(seconds=rng.randrange(10**8)) for _ in range(50)]
    got = js(
        browser,
        "var S = window.Shoreside, a = arguments;"
        "return [a[0].map(function (p) { return S.fmtPosition(p[0], p[1]); }),"
        " a[0].map(function (p) { return S.fmtDDM(p[0], p[1]); }),"
        " a[1].map(S.fmtSpeed), a[2].map(S.fmtNumber),"
        " a[3].map(function (t) { return S.fmtTime(t); }), a[4].map(S.fmtHeading)]",
        positions,
        speeds,
        numbers,
        [t.timestamp() for t in times],
        headings,
    )
    assert got[0] == [fmt_position(*p) for p in positions]
    assert got[1] == [fmt_ddm(*p) for p in positions]
    assert got[2] == [fmt_speed(s) for s in speeds]
    assert got[3] == [fmt_number(n) for n in numbers]
    assert got[4] == [fmt_time(t) for t in times]
    assert got[5] == [fmt_heading(h) for h in headings]
    # The fleet map's config carries the state channels as the server names them.
    channels = js(browser, "return window.Shoreside.json('fleet-map-config').channels")
    for key, state in state_channels_config().items():
        assert channels[key]["states"] == state["states"]


def test_the_fleet_map_panel_names_the_mode_and_the_armed_state(
    browser, live_server, operator_user, vessel_a: Vessel, make_fix
) -> None:
    fix_ingest(
        vessel=vessel_a,
        records=[
            make_fix(
                time=timezone.now().replace(microsecond=0).isoformat(),
                lat=-32.038,
                lon=115.3325,
                speed_mps=1.5,
                readings=AUTOPILOT,
            )
        ],
    )
    vessel_a.refresh_from_db()  # the move_to is measured from the fix just ingested
    command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -32.03, "lon": 115.33})
    log_in(browser, live_server, operator_user)
    wait_for(
        browser, lambda b: js(b, "return !!(window.shoresideFleet && window.shoresideFleet.fitted)")
    )
    browser.find_element(By.CSS_SELECTOR, '#fleet-map .vessel-icon[data-slug="spab"]').click()
    table = wait_for(
        browser, lambda b: b.find_element(By.CSS_SELECTOR, "#fleet-panel table.readings")
    )
    rows = {
        tr.find_element(By.TAG_NAME, "th").text: tr.find_element(By.TAG_NAME, "td")
        for tr in table.find_elements(By.TAG_NAME, "tr")
    }
    assert rows["Mode"].text == "HOLD" and rows["Armed"].text == "armed"
    assert rows["mission_item"].text == "3"
    assert rows["Speed"].text == "1.5 m/s (2.9 kn)"
    position = rows["Position"].find_element(By.CSS_SELECTOR, "span.position")
    assert position.text == "-32.03800°, 115.33250°"
    assert position.get_attribute("title") == "32°02.280′S 115°19.950′E"
    assert rows["Time"].text.startswith(fmt_time(vessel_a.fixes.get().recorded_at))
    # The mode and armed rows come first among the readings, before the sensors.
    keys = list(rows)
    assert keys.index("Mode") < keys.index("Armed") < keys.index("mission_item")
    # The marker's age and the command's age tell their time on hover; a target reads as a fix.
    fix_time = fmt_time(vessel_a.fixes.get().recorded_at)
    age = browser.find_element(
        By.CSS_SELECTOR, '#fleet-map .vessel-icon[data-slug="spab"] .vessel-age'
    )
    assert age.get_attribute("title") == "last fix " + fix_time
    command = wait_for(
        browser, lambda b: b.find_element(By.CSS_SELECTOR, "#fleet-panel .command-list li")
    )
    assert "-32.03000°, 115.33000°" in command.text
    created = command.find_element(By.CSS_SELECTOR, ".age").get_attribute("title")
    assert created == fmt_time(Command.objects.get().created_at)
    shot(browser, "display-1-fleet-panel")


def test_the_track_plots_mode_and_armed_as_named_steps(
    browser, live_server, operator_user, vessel_a: Vessel
) -> None:
    now = timezone.now().replace(second=0, microsecond=0)
    records = []
    for minute in range(120):
        # HOLD and disarmed, then armed in AUTO, then GUIDED for the last half hour.
        mode, armed = (4, 0) if minute >= 80 else (10, 1) if minute >= 30 else (15, 1)
        records.append(
            {
                "time": (now - dt.timedelta(minutes=minute)).isoformat(),
                "lat": -32 + minute / 10000,
                "lon": 115.7,
                "battery_v": 12.5,
                "readings": {"mode_number": mode, "armed": armed},
            }
        )
    fix_ingest(vessel=vessel_a, records=records)
    log_in(browser, live_server, operator_user)
    browser.get(live_server.url + f"/fleet/vessels/{vessel_a.slug}/track/?range=6h")
    wait_for(browser, lambda b: len(b.find_elements(By.CSS_SELECTOR, "#plots .plot")) == 3)
    plots = js(
        browser,
        "return window.shoresideTrack.plots.map(function (u) {"
        " var holder = u.root.parentNode, axis = u.axes[1];"
        " return {key: holder.dataset.key, plot: holder.dataset.plot || 'line',"
        " series: u.series.map(function (s) { return s.label; }),"
        " ticks: axis._values || null}; })",
    )
    by_key = {p["key"]: p for p in plots}
    # A state has no mean line: lowest and highest state of each bucket, drawn as steps.
    assert by_key["mode_number"]["plot"] == "steps"
    assert by_key["mode_number"]["series"] == ["time (UTC)", "min", "max"]
    assert sorted(by_key["mode_number"]["ticks"]) == ["AUTO", "GUIDED", "HOLD"]
    assert by_key["armed"]["plot"] == "steps"
    assert by_key["armed"]["ticks"] == ["disarmed", "armed"]
    assert by_key["battery_v"]["plot"] == "line" and "mean" in by_key["battery_v"]["series"]
    titles = [t.text for t in browser.find_elements(By.CSS_SELECTOR, "#plots .plot-title")]
    assert "Mode" in titles and "Armed" in titles
    # The legend names the state under the cursor.
    over = browser.find_element(By.CSS_SELECTOR, '#plots .plot[data-key="mode_number"] .u-over')
    js(browser, "arguments[0].scrollIntoView({block: 'center'})", over)
    from selenium.webdriver.common.action_chains import ActionChains

    ActionChains(browser).move_to_element_with_offset(
        over, over.size["width"] // 2 - 3, 0
    ).perform()
    legend = browser.find_element(
        By.CSS_SELECTOR, '#plots .plot[data-key="mode_number"] .u-legend'
    ).text
    # Both values under the cursor by name (min and max of the bucket), never a mode number.
    named = re.findall(r"\b(min|max):?\s*([A-Z_0-9]+)", legend)
    assert [k for k, _ in named] == ["min", "max"], legend
    assert all(v in ("HOLD", "AUTO", "GUIDED") for _, v in named), legend
    shot(browser, "display-2-track-states")


def test_the_fix_list_fits_a_1400_px_window_with_seconds_and_compact_readings(
    browser, live_server, operator_user, vessel_a: Vessel, vessel_b: Vessel, make_fix
) -> None:
    for key, label, unit in [
        ("water_temp_c", "Water temperature", "°C"),
        ("salinity_psu", "Salinity", "PSU"),
        ("humidity", "Humidity", "%"),
    ]:
        sensor_channel_save(channel=SensorChannel(key=key, label=label, unit=unit))
    # A boat's usual fix: the autopilot's state and two sensors; and a busy one with ten.
    usual = {**AUTOPILOT, "water_temp_c": 19.53, "salinity_psu": 35.21}
    busy = {**usual, "humidity": 41.0, "cpu_temp_c": 48.2, "rssi_dbm": -71.0, "pump_a": 0.82,
            "wind_speed_mps": 7.4}  # fmt: skip
    start = dt.datetime(2026, 11, 25, 14, 3, 2, tzinfo=dt.UTC)
    for vessel, readings in ((vessel_a, usual), (vessel_b, busy)):
        fix_ingest(
            vessel=vessel,
            records=[
                make_fix(
                    time=(start + dt.timedelta(seconds=5 * i)).isoformat(),
                    lat=-32.038 - i / 10000,
                    readings=readings,
                )
                for i in range(30)
            ],
        )
    log_in(browser, live_server, operator_user)
    before = browser.get_window_size()
    browser.set_window_size(1400, 900)
    try:
        for vessel in (vessel_a, vessel_b):
            browser.get(live_server.url + f"/admin/telemetry/fix/?vessel={vessel.pk}")
            width = js(browser, "return window.innerWidth")
            assert 1350 <= width <= 1400  # the window is the size the issue names
            shot(browser, f"display-3-fix-list-1400-{vessel.slug}")
            # No horizontal scroll: not of the page, nor of the list's own box.
            sizes = js(
                browser,
                "var box = document.querySelector('#changelist .results'),"
                " table = document.getElementById('result_list').getBoundingClientRect();"
                "return [document.documentElement.scrollWidth, box.scrollWidth, box.clientWidth,"
                " table.right]",
            )
            assert sizes[0] <= width and sizes[1] <= sizes[2] and sizes[3] <= width
            text = browser.find_element(By.ID, "result_list").text
            assert "2026-11-25 14:05:27 UTC" in text and "2026-11-25 14:05:22 UTC" in text
        # The usual fix: one line a row (every row one text line high).
        browser.get(live_server.url + f"/admin/telemetry/fix/?vessel={vessel_a.pk}")
        text = browser.find_element(By.ID, "result_list").text
        assert (
            "Mode HOLD · armed · Battery 12.6 V · mission_item 3 · Salinity 35.21 PSU · "
            "Water temperature 19.53 °C"
        ) in text
        heights = js(
            browser,
            "return Array.from(document.querySelectorAll('#result_list tbody tr'))"
            ".map(function (r) { return r.getBoundingClientRect().height; })",
        )
        assert len(heights) == 30 and max(heights) < 40
    finally:
        browser.set_window_size(before["width"], before["height"])  # the session's browser
