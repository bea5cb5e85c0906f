"""The mission planner in a real browser: click waypoints onto the map, drag one, save, reload
and find the mission intact; import a Mission Planner .waypoints file and see it on the map."""

from __future__ import annotations

from pathlib import Path

import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.support import expected_conditions as EC
from selenium.webdriver.support.ui import Select

from commands.models import Command
from edge_client.contract import geo
from telemetry.services import fix_ingest
from tests.browser.support import js, log_in, shot, wait_for
from tests.conftest import make_user
from vessels.display import fmt_position
from vessels.missions import legs
from vessels.models import Mission, Vessel
from vessels.services import mission_save, mission_save_items, vessel_create

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]

PLANNER_PERMS = [
    "vessels.view_vessel",
    "vessels.view_mission",
    "vessels.add_mission",
    "vessels.change_mission",
    "vessels.view_missionitem",
    "vessels.add_missionitem",
    "vessels.change_missionitem",
    "vessels.delete_missionitem",
    "commands.add_command",  # to send a mission
]


@pytest.fixture
def planner_user(db: None):
    return make_user("mia", PLANNER_PERMS)


def markers(browser) -> list:
    return browser.find_elements(By.CSS_SELECTOR, "#mission-map .waypoint-icon")


def planner_rows(browser) -> list[str]:
    return [
        td.text for td in browser.find_elements(By.CSS_SELECTOR, "#planner-list .planner-position")
    ]


def reviewed(browser) -> None:
    """Wait for the server's review of the route on screen (figures, checks) to be shown."""
    wait_for(
        browser,
        lambda b: js(b, "return document.getElementById('planner-list').dataset.state") == "ready",
    )


def open_planner(browser, url: str) -> None:
    browser.get(url)
    wait_for(browser, lambda b: js(b, "return !!window.shoresidePlanner"))
    js(browser, "document.querySelector('fieldset.planner').scrollIntoView()")


def test_a_three_point_mission_is_clicked_onto_the_map_dragged_saved_and_reloaded(
    browser, live_server, planner_user, vessel_a: Vessel, make_fix
) -> None:
    fix_ingest(vessel=vessel_a, records=[make_fix(lat=-31.9790, lon=115.8170)])
    log_in(browser, live_server, planner_user)
    open_planner(browser, live_server.url + "/admin/vessels/mission/add/")
    browser.find_element(By.NAME, "name").send_keys("Matilda Bay survey")
    Select(browser.find_element(By.NAME, "vessel")).select_by_visible_text("SPAB")
    js(browser, "document.querySelector('fieldset.planner').scrollIntoView()")
    shot(browser, "planner-1-empty")

    the_map = browser.find_element(By.ID, "mission-map")
    for dx, dy in ((-150, 80), (0, -100), (150, 60)):
        ActionChains(browser).move_to_element_with_offset(the_map, dx, dy).click().perform()
    wait_for(browser, lambda b: len(markers(b)) == 3)
    before = planner_rows(browser)
    assert len(before) == 3
    wait_for(browser, lambda b: "3 waypoints" in b.find_element(By.ID, "planner-total").text)
    shot(browser, "planner-2-three-waypoints")

    second = next(m for m in markers(browser) if m.text == "2")
    ActionChains(browser).drag_and_drop_by_offset(second, 90, 40).perform()
    wait_for(browser, lambda b: planner_rows(b)[1] != before[1])
    after = planner_rows(browser)
    assert after[0] == before[0] and after[2] == before[2]
    shot(browser, "planner-3-dragged")

    browser.find_element(By.NAME, "_continue").click()
    wait_for(browser, lambda b: "/change/" in b.current_url)
    mission = Mission.objects.get(name="Matilda Bay survey")
    saved = [(i.seq, fmt_position(i.lat, i.lon)) for i in mission.items.order_by("seq")]
    assert saved == [(1, after[0]), (2, after[1]), (3, after[2])]
    assert mission.vessel == vessel_a

    open_planner(browser, browser.current_url)  # a fresh load: what the server kept
    wait_for(browser, lambda b: len(markers(b)) == 3)
    assert planner_rows(browser) == after
    shot(browser, "planner-4-reloaded")

    # The planner's legs are the server's (vessels/missions.py), speed changes included.
    rows = [
        {"lat": i.lat, "lon": i.lon, "hold_s": 0, "speed_mps": 3.0 if i.seq == 2 else None}
        for i in mission.items.all()
    ]
    mission_save_items(mission=mission, items=rows)  # a speed change from item 2 on
    open_planner(browser, browser.current_url)
    reviewed(browser)
    shown = js(
        browser,
        "return window.shoresidePlanner.review.legs"
        ".map(function (l) { return [l.distance_m, l.time_s]; })",
    )
    items = [{"lat": i.lat, "lon": i.lon, "speed_mps": i.speed_mps} for i in mission.items.all()]
    server = legs(items, cruise_speed_mps=vessel_a.cruise_speed_mps, end="stop")
    assert shown == [
        [pytest.approx(leg.distance_m, rel=1e-9), pytest.approx(leg.time_s, rel=1e-9)]
        for leg in server
    ]


def test_deleting_and_reordering_in_the_list_keeps_rows_and_map_in_step(
    browser, live_server, planner_user, vessel_a: Vessel
) -> None:
    log_in(browser, live_server, planner_user)
    open_planner(browser, live_server.url + "/admin/vessels/mission/add/")
    browser.find_element(By.NAME, "name").send_keys("Reorder")
    the_map = browser.find_element(By.ID, "mission-map")
    for dx in (-120, 0, 120):
        ActionChains(browser).move_to_element_with_offset(the_map, dx, 0).click().perform()
    wait_for(browser, lambda b: len(markers(b)) == 3)
    first, second, third = planner_rows(browser)
    browser.find_elements(By.CSS_SELECTOR, "#planner-list .planner-down")[0].click()
    assert planner_rows(browser) == [second, first, third]
    browser.find_elements(By.CSS_SELECTOR, "#planner-list .planner-delete")[2].click()
    wait_for(browser, lambda b: len(markers(b)) == 2)
    assert planner_rows(browser) == [second, first]
    browser.find_element(By.NAME, "_continue").click()
    wait_for(browser, lambda b: "/change/" in b.current_url)
    items = Mission.objects.get(name="Reorder").items.order_by("seq")
    assert [fmt_position(i.lat, i.lon) for i in items] == [second, first]


WAYPOINTS = """QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t-31.979000\t115.817000\t0.000000\t1
1\t0\t3\t178\t0\t2.5\t0\t0\t0\t0\t0\t1
2\t0\t3\t16\t10\t0\t0\t0\t-31.980000\t115.820000\t0.000000\t1
3\t0\t3\t16\t0\t0\t0\t0\t-31.982000\t115.823000\t0.000000\t1
4\t0\t3\t16\t0\t0\t0\t0\t-31.978500\t115.824000\t0.000000\t1
"""


def test_a_mission_planner_waypoints_file_is_imported_and_shown_on_the_map(
    browser, live_server, planner_user, vessel_a: Vessel, tmp_path: Path
) -> None:
    path = tmp_path / "bay.waypoints"
    path.write_text(WAYPOINTS)
    log_in(browser, live_server, planner_user)
    browser.get(live_server.url + "/admin/vessels/mission/")
    browser.find_element(By.CSS_SELECTOR, 'a[href$="/mission/import/"]').click()
    browser.find_element(By.NAME, "file").send_keys(str(path))
    Select(browser.find_element(By.NAME, "vessel")).select_by_visible_text("SPAB")
    shot(browser, "import-1-form")
    browser.find_element(By.CSS_SELECTOR, "input[type=submit]").click()
    wait_for(browser, lambda b: "/change/" in b.current_url)
    wait_for(browser, lambda b: js(b, "return !!window.shoresidePlanner"))
    wait_for(browser, lambda b: len(markers(b)) == 3)
    js(browser, "document.querySelector('fieldset.planner').scrollIntoView()")
    assert planner_rows(browser) == [
        "-31.98000°, 115.82000°",
        "-31.98200°, 115.82300°",
        "-31.97850°, 115.82400°",
    ]
    assert "Imported" in browser.page_source
    shot(browser, "import-2-on-the-map")
    js(browser, "window.scrollTo(0, 0)")
    assert browser.find_element(By.CSS_SELECTOR, ".send-mission button").text.upper() == (
        "SEND TO SPAB"
    )
    shot(browser, "import-3-send-button")
    mission = Mission.objects.get()
    assert [i.speed_mps for i in mission.items.order_by("seq")] == [2.5, None, None]
    assert (mission.home_lat, mission.home_lon) == (-31.979, 115.817)


EVIL_NAME = """<img src=x onerror="document.title='pwned'">"""


def test_a_vessel_name_with_markup_shows_as_text_in_the_planner_and_runs_nothing(
    browser, live_server, planner_user, make_fix
) -> None:
    vessel = vessel_create(slug="evil", name=EVIL_NAME, kind="mavlink")
    fix_ingest(vessel=vessel, records=[make_fix(lat=-31.9790, lon=115.8170)])
    log_in(browser, live_server, planner_user)
    open_planner(browser, live_server.url + "/admin/vessels/mission/add/")
    title = browser.title
    Select(browser.find_element(By.NAME, "vessel")).select_by_visible_text(EVIL_NAME)
    js(
        browser,
        "var p = window.shoresidePlanner; p.render();"
        "p.layer.eachLayer(function (l) { if (l.getTooltip()) { l.openTooltip(); } });",
    )
    wait_for(browser, lambda b: b.find_elements(By.CSS_SELECTOR, ".leaflet-tooltip"))
    tooltip = browser.find_element(By.CSS_SELECTOR, ".leaflet-tooltip")
    assert js(browser, "return document.querySelector('.leaflet-tooltip').textContent") == (
        EVIL_NAME + " (last fix)"
    )
    assert not tooltip.find_elements(By.TAG_NAME, "img")
    assert browser.title == title != "pwned"


def five_waypoint_mission(vessel: Vessel) -> Mission:
    mission = mission_save(mission=Mission(name="Five", vessel=vessel))
    points = [geo.offset(-31.9790, 115.8170, 90, 150 * n) for n in range(1, 6)]
    return mission_save_items(mission=mission, items=[{"lat": a, "lon": b} for a, b in points])


def alert_text(browser) -> tuple[str, object]:
    alert = wait_for(browser, lambda b: EC.alert_is_present()(b))
    text = alert.text
    return text, alert


def test_send_refuses_an_unsaved_deletion_then_sends_exactly_what_the_screen_shows(
    browser, live_server, planner_user, vessel_a: Vessel, make_fix
) -> None:
    fix_ingest(vessel=vessel_a, records=[make_fix(lat=-31.9790, lon=115.8170)])
    mission = five_waypoint_mission(vessel_a)
    change = f"{live_server.url}/admin/vessels/mission/{mission.pk}/change/"
    log_in(browser, live_server, planner_user)
    open_planner(browser, change)
    wait_for(browser, lambda b: len(markers(b)) == 5)
    browser.find_elements(By.CSS_SELECTOR, "#planner-list .planner-delete")[4].click()
    wait_for(browser, lambda b: len(markers(b)) == 4)
    on_screen = planner_rows(browser)
    shot(browser, "send-1-waypoint-5-deleted")

    # Send with the deletion unsaved: refused in plain words, nothing queued.
    js(browser, "window.scrollTo(0, 0)")
    browser.find_element(By.CSS_SELECTOR, ".send-mission button").click()
    text, alert = alert_text(browser)
    assert text.startswith("Not sent: 4 waypoints on screen, 5 saved.")
    alert.accept()
    assert not Command.objects.exists()

    # Saved, the page is the mission again: the confirmation sums it up, and the queued
    # command holds the four waypoints the screen shows.
    browser.find_element(By.NAME, "_continue").click()
    wait_for(browser, lambda b: "was changed successfully" in b.page_source)
    open_planner(browser, browser.current_url)
    reviewed(browser)
    assert planner_rows(browser) == on_screen
    js(browser, "window.scrollTo(0, 0)")
    browser.find_element(By.CSS_SELECTOR, ".send-mission button").click()
    text, alert = alert_text(browser)
    assert text == (
        "Send to SPAB: 4 waypoints · 450 m · 5 min. SPAB's last fix is 150 m from waypoint 1; "
        "then it stops at the last waypoint."
    )
    alert.accept()
    wait_for(browser, lambda b: "queued as command" in b.page_source)
    shot(browser, "send-2-queued")
    queued = Command.objects.get().params["items"]
    assert [fmt_position(i["lat"], i["lon"]) for i in queued] == on_screen


def test_an_impossible_row_and_an_over_long_leg_are_marked_live(
    browser, live_server, planner_user, vessel_a: Vessel, settings
) -> None:
    settings.MISSION_MAX_LEG_M = 50_000
    mission = five_waypoint_mission(vessel_a)
    log_in(browser, live_server, planner_user)
    open_planner(browser, f"{live_server.url}/admin/vessels/mission/{mission.pk}/change/")
    reviewed(browser)
    assert not browser.find_elements(By.CSS_SELECTOR, "#mission-map path.planner-bad-leg")
    # Row 2 typed as latitude 95; row 4 moved 113 km east.
    lat = browser.find_element(By.NAME, "items-1-lat")
    lat.clear()
    lat.send_keys("95")
    far = geo.offset(-31.9790, 115.8170, 90, 113_000)
    lon = browser.find_element(By.NAME, "items-3-lon")
    lon.clear()
    lon.send_keys(f"{far[1]:.6f}")
    wait_for(browser, lambda b: len(markers(b)) == 4)
    reviewed(browser)
    js(browser, "document.querySelector('fieldset.planner').scrollIntoView()")
    shot(browser, "planner-5-impossible-row-and-long-leg")
    bad_row = browser.find_element(By.CSS_SELECTOR, "#planner-list tr.planner-row-problem")
    assert "latitude 95 is not within -90…90" in bad_row.text
    # Legs 2 → 3 and 3 → 4 (of the four drawable waypoints) run to and from the far one.
    assert len(browser.find_elements(By.CSS_SELECTOR, "#mission-map path.planner-bad-leg")) == 2
    problems = browser.find_element(By.ID, "planner-problems").text
    assert "longer than the limit of 50.0 km" in problems
    assert "row 2: latitude 95 is not within -90…90" in problems


def start_leg(browser) -> list | None:
    """The dashed leg to waypoint 1 as drawn: [[lat, lon], [lat, lon]], or None."""
    return js(
        browser,
        "var found = null; window.shoresidePlanner.layer.eachLayer(function (l) {"
        " if (l.options && l.options.className === 'planner-start-leg') {"
        "  found = l.getLatLngs().map(function (p) { return [p.lat, p.lng]; }); } });"
        " return found;",
    )


def row_input(browser, kind: str, row: int):
    return browser.find_elements(By.CSS_SELECTOR, f"#planner-list .planner-{kind}-input")[row]


def test_the_map_comes_first_holds_and_speeds_are_set_in_rows_and_the_leg_to_waypoint_1_is_drawn(
    browser, live_server, planner_user, vessel_a: Vessel, make_fix
) -> None:
    fix_ingest(vessel=vessel_a, records=[make_fix(lat=-31.9790, lon=115.8170)])
    mission = five_waypoint_mission(vessel_a)
    log_in(browser, live_server, planner_user)
    browser.get(f"{live_server.url}/admin/vessels/mission/{mission.pk}/change/")
    wait_for(browser, lambda b: js(b, "return !!window.shoresidePlanner"))
    reviewed(browser)
    # The map above the name and the notes.
    top = lambda css: browser.find_element(By.CSS_SELECTOR, css).rect["y"]  # noqa: E731
    assert top("#mission-map") < top("input[name=name]") < top("textarea[name=notes]")
    shot(browser, "planner-6-map-first")

    # No home: the dashed leg runs from the vessel's last fix to waypoint 1.
    first = mission.items.order_by("seq").first()
    assert start_leg(browser) == [
        [pytest.approx(-31.9790), pytest.approx(115.8170)],
        [pytest.approx(first.lat), pytest.approx(first.lon)],
    ]
    legs_shown = browser.find_elements(By.CSS_SELECTOR, "#planner-list .planner-leg")
    assert legs_shown[0].text == "from SPAB 150 m"

    # Hold and speed typed in waypoint 2's row: the inline row (the form) takes them, the
    # input keeps the focus while the map and figures redraw, and the totals count the hold.
    hold = row_input(browser, "hold", 1)
    hold.clear()
    hold.send_keys("45")
    wait_for(browser, lambda b: "(holds 45 s)" in b.find_element(By.ID, "planner-total").text)
    assert browser.find_element(By.NAME, "items-1-hold_s").get_attribute("value") == "45"
    assert js(browser, "return document.activeElement.dataset.for") == "items-1-hold_s"
    speed = row_input(browser, "speed", 1)
    # A typo is marked in the row at once, not read as a number (parseFloat would take 4).
    speed.send_keys("4o")
    wait_for(browser, lambda b: "planner-input-invalid" in speed.get_attribute("class"))
    assert js(browser, "return document.activeElement.validity.valid") is False
    assert "not a number of m/s" in speed.get_attribute("title")
    speed.clear()
    speed.send_keys("3")
    wait_for(browser, lambda b: "planner-input-invalid" not in speed.get_attribute("class"))
    reviewed(browser)
    assert browser.find_element(By.NAME, "items-1-speed_mps").get_attribute("value") == "3"
    wait_for(
        browser, lambda b: js(b, "return window.shoresidePlanner.review.legs[1].speed_mps") == 3
    )

    # A home: the dashed leg now runs from there.
    for name, value in (("home_lat", "-31.9800"), ("home_lon", "115.8150")):
        box = browser.find_element(By.NAME, name)
        box.clear()
        box.send_keys(value)
    wait_for(browser, lambda b: start_leg(b)[0] == [pytest.approx(-31.98), pytest.approx(115.815)])
    wait_for(
        browser,
        lambda b: b.find_elements(By.CSS_SELECTOR, "#planner-list .planner-leg")[0].text.startswith(
            "from home "
        ),
    )
    js(browser, "document.querySelector('fieldset.planner').scrollIntoView()")
    shot(browser, "planner-7-hold-speed-home-leg")

    browser.find_element(By.NAME, "_continue").click()
    wait_for(browser, lambda b: "was changed successfully" in b.page_source)
    second = Mission.objects.get(pk=mission.pk).items.order_by("seq")[1]
    assert (second.hold_s, second.speed_mps) == (45, 3.0)
    assert Mission.objects.get(pk=mission.pk).home == (-31.98, 115.815)


def test_after_send_the_browser_is_on_the_commands_page_and_follows_it_live(
    browser, live_server, vessel_a: Vessel, make_fix, boat_a, settings
) -> None:
    settings.FLEET_MAP_POLL_S = 1
    fix_ingest(vessel=vessel_a, records=[make_fix(lat=-31.9790, lon=115.8170)])
    mission = five_waypoint_mission(vessel_a)
    user = make_user("max", [*PLANNER_PERMS, "commands.view_command"])
    log_in(browser, live_server, user)
    open_planner(browser, f"{live_server.url}/admin/vessels/mission/{mission.pk}/change/")
    reviewed(browser)
    js(browser, "window.scrollTo(0, 0)")
    browser.find_element(By.CSS_SELECTOR, ".send-mission button").click()
    text, alert = alert_text(browser)
    assert text.startswith("Send to SPAB: 5 waypoints")
    alert.accept()
    command = wait_for(browser, lambda b: Command.objects.first())
    wait_for(
        browser, lambda b: b.current_url.endswith(f"/admin/commands/command/{command.pk}/change/")
    )
    assert "queued as command" in browser.page_source

    def status(b) -> str:
        return b.find_element(By.CSS_SELECTOR, ".field-status_badge .command-status").text

    assert status(browser) == "queued"
    assert "following it live" in browser.find_element(By.ID, "command-live").text
    js(browser, "window.notReloaded = true")
    shot(browser, "send-3-command-queued")

    # The boat fetches it, acknowledges it, reports it done: the page follows, no reload.
    assert boat_a.get("/api/v1/boat/commands/").status_code == 200
    wait_for(browser, lambda b: status(b) == "sent")
    ack = f"/api/v1/boat/commands/{command.uid}/ack/"
    assert boat_a.post(ack, {"status": "acknowledged"}, format="json").status_code == 200
    wait_for(browser, lambda b: status(b) == "acknowledged")
    shot(browser, "send-4-command-acknowledged")
    assert (
        boat_a.post(
            ack, {"status": "done", "detail": "mission complete"}, format="json"
        ).status_code
        == 200
    )
    wait_for(browser, lambda b: status(b) == "done")
    assert js(browser, "return window.notReloaded") is True
    live = browser.find_element(By.ID, "command-live").text
    assert live.startswith("Status: done “mission complete”") and "finished" in live
    assert "(done)" in browser.find_element(By.CSS_SELECTOR, "#content > h2").text
    assert "mission complete" in browser.find_element(By.CSS_SELECTOR, ".field-result_detail").text
    shot(browser, "send-5-command-done-live")
