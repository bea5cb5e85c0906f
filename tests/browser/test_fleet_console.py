"""The fleet map as a console (issue 18 §2), in a real browser: a vessel's trail fading with
age, the mission it runs with the waypoint it is heading to, the list of vessels beside the
map, and labels that give way to each other when the fleet is zoomed out."""

from __future__ import annotations

import datetime as dt
import itertools
import re

import pytest
from django.utils import timezone
from selenium.webdriver.common.by import By

from alerts.selectors import vessel_endurance_hours
from commands.models import Command
from commands.services import command_ack, command_claim_open, command_enqueue
from telemetry.services import fix_ingest
from tests.alerts.test_evaluator import drain
from tests.browser.support import js, log_in, set_view, shot, wait_for
from tests.browser.test_fleet_map import HOME, simulated_boat  # noqa: F401 (a fixture)
from tests.edge_client.helpers import wait_until
from vessels.models import Vessel
from vessels.services import vessel_create

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]

# A square mission off Fremantle; the boat came from the west to waypoint 1 and is halfway
# along the leg to waypoint 2.
ROUTE = [(-32.000, 115.700), (-32.000, 115.712), (-32.009, 115.712), (-32.009, 115.700)]
START = (-31.996, 115.688)
HERE = (-32.000, 115.706)


@pytest.fixture(autouse=True)
def _fast_polls(settings) -> None:
    settings.FLEET_MAP_POLL_S = 1
    settings.FLEET_MAP_TRAIL_REFRESH_S = 5


def iso(t: dt.datetime) -> str:
    return t.isoformat().replace("+00:00", "Z")


def between(a: tuple[float, float], b: tuple[float, float], f: float) -> tuple[float, float]:
    return a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f


def sail_the_last_hour(vessel: Vessel) -> None:
    """A fix every 20 s for an hour: 40 min from START to waypoint 1, 20 min to HERE; the last
    fixes say the autopilot is heading to waypoint 2 of 4."""
    now = timezone.now()
    records = []
    for i in range(181):
        t = now - dt.timedelta(seconds=20 * (180 - i))
        lat, lon = (
            between(START, ROUTE[0], i / 120)
            if i <= 120
            else between(ROUTE[0], HERE, (i - 120) / 60)
        )
        readings = {"waypoint": 1 if i <= 120 else 2, "waypoints": 4}
        records.append({"time": iso(t), "lat": lat, "lon": lon, "heading_deg": 90.0,
                        "battery_v": 12.4, "readings": readings})  # fmt: skip
    fix_ingest(vessel=vessel, records=records)


def run_mission(vessel: Vessel) -> Command:
    items = [{"lat": lat, "lon": lon} for lat, lon in ROUTE]
    command = command_enqueue(vessel=vessel, kind="mission", params={"items": items})
    command_claim_open(vessel=vessel)
    command, _ = command_ack(vessel=vessel, uid=command.uid, status="acknowledged")
    return command


def overlays_drawn(browser) -> bool:
    return bool(
        js(
            browser,
            "var f = window.shoresideFleet;return !!(f && f.fitted && f.overlays.refreshes > 0)",
        )
    )


def paths(browser, selector: str) -> list[dict]:
    return js(
        browser,
        "return Array.from(document.querySelectorAll(arguments[0])).map(function (p) {"
        "  return {cls: p.getAttribute('class'), band: p.dataset.band, slug: p.dataset.slug,"
        "    opacity: Number(p.getAttribute('stroke-opacity')), d: p.getAttribute('d')}; })",
        selector,
    )


def test_the_trail_fades_and_the_running_mission_shows_its_waypoint(
    browser, live_server, operator_user, vessel_a: Vessel, vessel_b: Vessel
) -> None:
    sail_the_last_hour(vessel_a)
    run_mission(vessel_a)
    fix_ingest(
        vessel=vessel_b,
        records=[{"time": iso(timezone.now()), "lat": -32.02, "lon": 115.69, "battery_v": 11.9}],
    )
    log_in(browser, live_server, operator_user)
    wait_for(browser, overlays_drawn)
    set_view(browser, HERE, 14)

    # The trail: one run per age band, each older band fainter than the one after it.
    trail = wait_for(
        browser, lambda b: len(paths(b, "path.fleet-trail")) >= 5 and paths(b, "path.fleet-trail")
    )
    assert {p["slug"] for p in trail} == {"spab"}
    opacity = {int(p["band"]): p["opacity"] for p in trail}
    assert sorted(opacity) == list(range(6))  # an hour of fixes fills every band
    assert [opacity[b] for b in sorted(opacity)] == sorted(opacity.values(), reverse=True)
    assert opacity[0] > 0.8 and opacity[5] < 0.25

    # The mission: the leg it is on cut where the boat is, waypoint 1 done, 2 ahead.
    legs = paths(browser, "path.mission-leg")
    states = sorted(p["cls"].replace("mission-leg ", "").split()[0] for p in legs)
    assert states == ["active", "done", "todo", "todo"]  # 1→here, here→2, 2→3, 3→4
    done = next(p for p in legs if "done" in p["cls"])
    todo = next(p for p in legs if "todo" in p["cls"])
    active = next(p for p in legs if "active" in p["cls"])
    assert done["opacity"] < todo["opacity"] <= active["opacity"]  # done legs dimmed
    assert "to-current" in active["cls"]
    marks = {
        m.text: m.get_attribute("class")
        for m in browser.find_elements(By.CSS_SELECTOR, "#fleet-map .mission-wp")
    }
    assert set(marks) == {"1", "2", "3", "4"}
    assert "done" in marks["1"] and "current" in marks["2"] and "todo" in marks["4"]

    # The list beside the map: both vessels, their state, age and battery, the progress.
    rows = {
        r.get_attribute("data-slug"): r.text
        for r in browser.find_elements(By.CSS_SELECTOR, "#fleet-panel table.vessel-list tbody tr")
    }
    assert set(rows) == {"spab", "spab-2"}
    assert "SPAB" in rows["spab"] and "wp 2/4" in rows["spab"] and "12.4 V" in rows["spab"]
    assert "reporting" in rows["spab-2"] and "11.9 V" in rows["spab-2"]
    ages = [c.text for c in browser.find_elements(By.CSS_SELECTOR, "table.vessel-list td.fix-age")]
    assert len(ages) == 2 and all(re.fullmatch(r"\d+ s", age) for age in ages), ages

    # A click in the list selects the vessel: its row, its panel, the map brought to it.
    browser.find_element(By.CSS_SELECTOR, 'table.vessel-list tr[data-slug="spab"]').click()
    wait_for(
        browser, lambda b: "Heading to waypoint 2 of 4" in b.find_element(By.ID, "fleet-panel").text
    )
    assert "selected" in browser.find_element(
        By.CSS_SELECTOR, 'table.vessel-list tr[data-slug="spab"]'
    ).get_attribute("class")
    label = wait_for(
        browser,
        lambda b: b.find_element(By.CSS_SELECTOR, "#fleet-map .mission-wp.current .wp-label"),
    )
    assert label.text == "SPAB: waypoint 2 of 4"
    shot(browser, "console-1-trail-and-mission")

    browser.find_element(By.CSS_SELECTOR, 'table.vessel-list tr[data-slug="spab-2"]').click()
    wait_for(browser, lambda b: "SPAB 2" in b.find_element(By.CSS_SELECTOR, "#fleet-panel h2").text)
    wait_for(  # brought to the middle of the map
        browser,
        lambda b: abs(js(b, "return window.shoresideFleet.map.getCenter().lat") + 32.02) < 1e-3,
    )
    assert not browser.find_elements(By.CSS_SELECTOR, "#fleet-map .wp-label")  # SPAB's only
    shot(browser, "console-2-second-vessel-selected")

    # A shorter trail from the map's control: fewer bands' worth of points, read again.
    refreshes = js(browser, "return window.shoresideFleet.overlays.refreshes")
    js(
        browser,
        "var s = document.querySelector('.trail-control select'); s.value = '15';"
        "s.dispatchEvent(new Event('change'))",
    )
    wait_for(
        browser, lambda b: js(b, "return window.shoresideFleet.overlays.refreshes") > refreshes
    )
    oldest = js(
        browser,
        "var t = window.shoresideFleet.overlays.trails.spab.lines;"
        "return Date.now() / 1000 - t[0][0][0]",
    )
    assert oldest <= 15 * 60 + 5


def label_boxes(browser) -> list[dict]:
    return js(
        browser,
        "var labels = document.querySelectorAll('#fleet-map .vessel-label');"
        "return Array.from(labels).map(function (l) {"
        "  var r = l.getBoundingClientRect();"
        "  return {slug: l.parentNode.dataset.slug, hidden: l.classList.contains('decluttered'),"
        "    visible: getComputedStyle(l).visibility === 'visible',"
        "    more: l.querySelector('.label-more').textContent,"
        "    left: r.left, right: r.right, top: r.top, bottom: r.bottom}; })",
    )


def overlap(a: dict, b: dict) -> bool:
    return (
        a["left"] < b["right"]
        and b["left"] < a["right"]
        and a["top"] < b["bottom"]
        and b["top"] < a["bottom"]
    )


def test_labels_of_a_crowded_fleet_do_not_overlap_when_zoomed_out(
    browser, live_server, operator_user
) -> None:
    now = iso(timezone.now())
    for i in range(12):
        vessel = vessel_create(slug=f"boat-{i:02d}", name=f"Boat {i:02d}", kind="mavlink")
        # A cluster a few hundred metres across, and one boat apart to the south.
        lat, lon = (
            (-32.05 + (i % 4) * 0.002, 115.74 + (i // 4) * 0.002) if i < 11 else (-32.3, 115.6)
        )
        fix_ingest(vessel=vessel, records=[{"time": now, "lat": lat, "lon": lon}])
    log_in(browser, live_server, operator_user)
    wait_for(
        browser, lambda b: js(b, "return !!(window.shoresideFleet && window.shoresideFleet.fitted)")
    )
    wait_for(browser, lambda b: len(label_boxes(b)) == 12)
    set_view(browser, (-32.15, 115.7), 9)

    def settled(b) -> list[dict] | None:
        boxes = label_boxes(b)
        shown = [x for x in boxes if x["visible"]]
        return (
            boxes if all(not overlap(a, c) for a, c in itertools.combinations(shown, 2)) else None
        )

    boxes = wait_for(browser, settled)
    shown = [x for x in boxes if x["visible"]]
    hidden = [x for x in boxes if x["hidden"]]
    assert len(shown) >= 2 and len(hidden) >= 8  # the cluster gave way; the lone boat did not
    assert any(x["slug"] == "boat-11" for x in shown)
    # The labels kept count the ones they hide.
    assert sum(int(x["more"] or "0") for x in shown) == len(hidden)
    shot(browser, "console-3-crowded-fleet-zoomed-out")

    # "+N" zooms in to the boats it stands for; closer in, more labels show.
    zoom = js(browser, "return window.shoresideFleet.map.getZoom()")
    browser.find_element(
        By.CSS_SELECTOR, "#fleet-map .vessel-label .label-more:not([hidden])"
    ).click()
    wait_for(browser, lambda b: js(b, "return window.shoresideFleet.map.getZoom()") > zoom)

    def more_shown(b) -> bool:
        boxes = settled(b)
        return boxes is not None and len([x for x in boxes if x["visible"]]) > len(shown)

    wait_for(browser, more_shown)
    assert js(browser, "return window.shoresideFleet.selected") is None  # zoomed, not selected
    shot(browser, "console-4-crowded-fleet-zoomed-in")


def test_the_map_fills_the_window_and_the_app_list_follows(
    browser, live_server, operator_user
) -> None:
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: js(b, "return !!window.shoresideFleet"))
    box = js(
        browser,
        "var r = document.getElementById('fleet-map').getBoundingClientRect();"
        "return [r.top, r.bottom, r.width, window.innerHeight, window.innerWidth]",
    )
    top, bottom, width, height, window_width = box
    assert top < 80 and height - bottom < 20  # from under the header to the window's bottom
    assert width > window_width * 0.55
    apps = browser.find_element(By.ID, "content-main")
    assert apps.location["y"] >= bottom  # the app list is below the map
    assert "Administration" in browser.find_element(By.CSS_SELECTOR, "h1.admin-index-title").text
    js(browser, "document.querySelector('h1.admin-index-title').scrollIntoView()")
    shot(browser, "console-7-app-list-below-the-map")


def test_a_mission_run_by_the_simulated_boat_shows_the_waypoint_it_heads_for(
    browser,
    live_server,
    operator_user,
    simulated_boat: Vessel,  # noqa: F811 (the fixture imported above)
) -> None:
    """The real edge client and Rover simulator: the waypoint numbers come from the boat."""
    vessel = simulated_boat
    wait_until(lambda: Vessel.objects.get(pk=vessel.pk).last_fix, 30, "a first fix")
    vessel.refresh_from_db()
    # Three waypoints 300-600 m from home: the simulator (20 m/s) takes several seconds a leg.
    route = [
        (HOME[0] + 0.003, HOME[1]),
        (HOME[0] + 0.003, HOME[1] + 0.004),
        (HOME[0], HOME[1] + 0.004),
    ]
    items = [{"lat": lat, "lon": lon, "hold_s": 3} for lat, lon in route]
    command = command_enqueue(vessel=vessel, kind="mission", params={"items": items})
    log_in(browser, live_server, operator_user)
    wait_for(
        browser, lambda b: js(b, "return !!(window.shoresideFleet && window.shoresideFleet.fitted)")
    )
    set_view(browser, HOME, 15)
    browser.find_element(By.CSS_SELECTOR, 'table.vessel-list tr[data-slug="spab"]').click()

    def heading_to(b) -> str | None:
        text = b.find_element(By.ID, "fleet-panel").text
        found = re.search(r"Heading to waypoint (\d) of 3", text)
        return found and found.group(1)

    wait_until(lambda: Command.objects.get(pk=command.pk).status == "acknowledged", 30, "the ack")
    first = wait_for(browser, heading_to, 60)
    shot(browser, "console-5-simulated-boat-mission")
    # The boat moves on: a later waypoint, the legs behind it dimmed.
    wait_for(browser, lambda b: (heading_to(b) or "0") > first, 90)
    assert browser.find_elements(By.CSS_SELECTOR, "#fleet-map path.mission-leg.done")
    assert browser.find_elements(By.CSS_SELECTOR, "#fleet-map .mission-wp.current")
    shot(browser, "console-6-simulated-boat-next-waypoint")


def test_the_vessels_panel_shows_its_battery_endurance(
    browser, live_server, operator_user, settings
) -> None:
    settings.ALERTS_BATTERY_EMPTY_V = 11.0
    falling = vessel_create(slug="falling", name="Falling", kind="mavlink")
    drain(falling, 50, start_v=12.5, per_hour=0.02)  # two days, the sun on top
    vessel_create(slug="new", name="New", kind="mavlink")
    fix_ingest(
        vessel=Vessel.objects.get(slug="new"),
        records=[{"time": iso(timezone.now()), "lat": -32.0, "lon": 115.7, "battery_v": 12.6}],
    )
    log_in(browser, live_server, operator_user)

    def endurance_row(b) -> str | None:
        rows = b.find_elements(By.XPATH, "//table[@class='readings']//tr[th='Endurance']/td")
        return rows[0].text if rows else None

    browser.find_element(By.CSS_SELECTOR, 'table.vessel-list tr[data-slug="falling"]').click()
    said = wait_for(browser, endurance_row)
    # As the endurance rule judges it: about 30 h from the last night's trough at 0.02 V/h.
    hours = vessel_endurance_hours(vessel=falling)
    assert said == f"{hours:.0f} h to empty (11 V), day over day"
    shot(browser, "console-5-endurance-in-the-panel")
    browser.find_element(By.CSS_SELECTOR, 'table.vessel-list tr[data-slug="new"]').click()
    wait_for(browser, lambda b: endurance_row(b) == "not enough history yet (it needs two days "
             "of reports)")  # fmt: skip
