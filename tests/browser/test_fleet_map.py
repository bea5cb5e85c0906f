"""The fleet map in a real browser: the operator's home after logging in, refreshing itself
without moving the view, the side panel, commands from the map (and none without the right),
and a move_to carried out by the real edge client driving the Rover simulator."""

from __future__ import annotations

import datetime as dt
import random
from pathlib import Path

import pytest
from django.core.management import call_command
from django.utils import timezone
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

from commands.models import Command
from commands.services import command_enqueue
from edge_client.contract.geo import bearing_deg, distance_m, offset
from telemetry.models import SensorChannel
from telemetry.services import fix_ingest, sensor_channel_save
from tests.browser.support import js, log_in, set_view, shot, wait_for
from tests.conftest import make_user
from tests.edge_client.conftest import free_port
from tests.edge_client.helpers import start, stop, wait_until
from vessels.models import Vessel
from vessels.services import vessel_key_issue

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]

DEMO_NAMES = {"spab": "SPAB", "spab-2": "SPAB 2", "glider": "Wave Glider"}


@pytest.fixture(autouse=True)
def _fast_polls(settings) -> None:
    settings.FLEET_MAP_POLL_S = 1


@pytest.fixture
def demo_operator(tmp_path: Path):
    call_command("seed_demo", password="pw-operator", keys_file=str(tmp_path / "keys.json"))
    from django.contrib.auth.models import User

    return User.objects.get(username="operator")


def on_the_map(browser) -> dict[str, str]:
    """{slug: label text} of the vessel markers drawn. The text is the marker's own, shown or
    not: a label that gives way to a nearer one (fleet_console.js declutter) is hidden, and
    Selenium's ``.text`` of a hidden element is empty."""
    return {
        m.get_attribute("data-slug"): " ".join(m.get_attribute("textContent").split())
        for m in browser.find_elements(By.CSS_SELECTOR, "#fleet-map .vessel-icon[data-slug]")
    }


def fleet_ready(browser) -> bool:
    return bool(js(browser, "return !!(window.shoresideFleet && window.shoresideFleet.fitted)"))


def polls(browser) -> int:
    return js(browser, "return window.shoresideFleet.polls")


def open_panel(browser, slug: str) -> None:
    browser.find_element(By.CSS_SELECTOR, f'#fleet-map .vessel-icon[data-slug="{slug}"]').click()
    wait_for(
        browser, lambda b: DEMO_NAMES.get(slug, slug) in b.find_element(By.ID, "fleet-panel").text
    )


def test_an_operator_logs_in_and_lands_on_the_fleet_map_with_the_demo_vessels(
    browser, live_server, demo_operator
) -> None:
    log_in(browser, live_server, demo_operator)
    assert browser.current_url == live_server.url + "/admin/"
    wait_for(browser, lambda b: fleet_ready(b) and len(on_the_map(b)) == 3)
    labels = on_the_map(browser)
    for slug, name in DEMO_NAMES.items():
        assert labels[slug].startswith(name)
    statuses = {
        m.get_attribute("data-slug"): m.get_attribute("data-status")
        for m in browser.find_elements(By.CSS_SELECTOR, "#fleet-map .vessel-icon[data-slug]")
    }
    assert set(statuses.values()) <= {"reporting", "overdue"}
    panel = browser.find_element(By.ID, "fleet-panel").text
    assert all(name in panel for name in DEMO_NAMES.values())
    shot(browser, "fleet-1-home")

    open_panel(browser, "spab")
    panel = browser.find_element(By.ID, "fleet-panel").text
    assert "Water temperature" in panel and "°C" in panel and "Salinity" in panel
    assert "Battery" in panel and " V" in panel
    buttons = [b.text for b in browser.find_elements(By.CSS_SELECTOR, "#fleet-panel button.action")]
    assert buttons == [
        "Move to a point…",
        "Hold position",
        "Resume mission (AUTO)",
        "Return home (RTL)",
    ]
    wait_for(browser, lambda b: "move_to" in b.find_element(By.ID, "fleet-panel").text)  # seeded
    shot(browser, "fleet-2-panel-spab")

    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .back").click()
    open_panel(browser, "glider")
    buttons = [b.text for b in browser.find_elements(By.CSS_SELECTOR, "#fleet-panel button.action")]
    assert buttons == ["Fixed heading…", "Hold position", "Marker light: on", "Marker light: off"]
    shot(browser, "fleet-3-panel-glider")

    # From the panel to the glider's track: its demo history, a plot per channel.
    browser.find_element(By.LINK_TEXT, "Track and plots").click()
    wait_for(browser, lambda b: "/fleet/vessels/glider/track/" in b.current_url)
    wait_for(browser, lambda b: len(b.find_elements(By.CSS_SELECTOR, "#plots .plot")) == 4)
    assert "fixes in range" in browser.find_element(By.ID, "track-summary").text
    js(browser, "document.getElementById('plots').scrollIntoView()")
    shot(browser, "fleet-4-glider-plots")


def test_the_fleet_map_follows_new_fixes_without_moving_the_view(
    browser, live_server, operator_user, vessel_a: Vessel, make_fix
) -> None:
    fix_ingest(vessel=vessel_a, records=[make_fix(time=timezone.now().isoformat())])
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: fleet_ready(b) and "spab" in on_the_map(b))
    js(browser, "window.shoresideFleet.map.panBy([120, -60], {animate: false})")
    view = js(browser, "var c = window.shoresideFleet.map.getCenter(); return [c.lat, c.lng]")

    later = timezone.now() + dt.timedelta(seconds=1)
    fix_ingest(vessel=vessel_a, records=[make_fix(time=later.isoformat(), lat=-31.9600)])
    wait_for(
        browser,
        lambda b: js(b, "return window.shoresideFleet.markers.spab.getLatLng().lat") == -31.96,
    )
    seen = polls(browser)
    wait_for(browser, lambda b: polls(b) >= seen + 2)  # two more polls, answered 304
    assert js(browser, "return window.shoresideFleet.notModified") >= 2
    assert (
        js(browser, "var c = window.shoresideFleet.map.getCenter(); return [c.lat, c.lng]") == view
    )


def test_an_operator_without_the_add_command_permission_sees_no_command_buttons(
    browser, live_server, vessel_a: Vessel, make_fix
) -> None:
    fix_ingest(vessel=vessel_a, records=[make_fix(time=timezone.now().isoformat())])
    watcher = make_user("carol", ["vessels.view_vessel", "commands.view_command"])
    log_in(browser, live_server, watcher)
    wait_for(browser, lambda b: fleet_ready(b) and "spab" in on_the_map(b))
    open_panel(browser, "spab")
    wait_for(browser, lambda b: "Recent commands" in b.find_element(By.ID, "fleet-panel").text)
    assert browser.find_elements(By.CSS_SELECTOR, "#fleet-panel button.action") == []
    assert "Track" not in browser.find_element(By.ID, "fleet-panel").text  # no view_fix
    # And the API the buttons would call refuses them anyway.
    status = js(
        browser,
        "var cfg = window.shoresideFleet.cfg;"
        "return fetch('/api/v1/vessels/spab/commands/', {method: 'POST',"
        " credentials: 'same-origin',"
        " headers: {'Content-Type': 'application/json', 'X-CSRFToken': cfg.csrfToken},"
        " body: JSON.stringify({kind: 'hold', params: {}})}).then(r => r.status)",
    )
    assert status == 403 and Command.objects.count() == 0


def geo_pairs() -> list[tuple[float, float, float, float]]:
    """Pairs of points to measure: known places, the awkward ones (the same point, the poles,
    the antimeridian, antipodes), pairs anywhere and pairs a map click apart (under 10 km)."""
    rng = random.Random(17)
    pairs = [
        (-31.9790, 115.8170, -31.9800, 115.8200),  # across Matilda Bay
        (-32.0560, 115.7400, -32.0380, 115.3325),  # Fremantle to the glider's area
        (51.4778, -0.0015, 40.7486, -73.9864),  # Greenwich to New York
        (0.0, 179.9, 0.0, -179.9),  # across the antimeridian
        (-32.0, 115.0, -32.0, 115.0),  # the same point
        (90.0, 0.0, -90.0, 0.0),  # pole to pole
        (10.0, 20.0, -10.0, -160.0),  # antipodes
        (89.9, 45.0, 89.9, -135.0),  # over the pole
    ]
    for _ in range(300):
        pairs.append(
            (
                rng.uniform(-90, 90),
                rng.uniform(-180, 180),
                rng.uniform(-90, 90),
                rng.uniform(-180, 180),
            )
        )
    for _ in range(200):
        lat, lon = rng.uniform(-80, 80), rng.uniform(-180, 180)
        pairs.append((lat, lon, *offset(lat, lon, rng.uniform(0, 360), rng.uniform(0.5, 10_000))))
    return pairs


def test_the_map_measures_distance_and_bearing_as_the_server_does(
    browser, live_server, operator_user
) -> None:
    """mapkit.js keeps the one JavaScript copy of edge_client.contract.geo (a page cannot import
    Python): it must give the contract's figures, to rounding, on every kind of pair."""
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: js(b, "return !!(window.Shoreside && window.Shoreside.geo)"))
    pairs = geo_pairs()
    got = js(
        browser,
        "var g = window.Shoreside.geo;"
        "return arguments[0].map(function (p) {"
        " return [g.distance(p[0], p[1], p[2], p[3]), g.bearing(p[0], p[1], p[2], p[3])]; })",
        pairs,
    )
    assert len(got) == len(pairs) > 500
    for (metres, bearing), pair in zip(got, pairs, strict=True):
        assert metres == pytest.approx(distance_m(*pair), rel=1e-9, abs=1e-6), pair
        # Degrees apart on the circle (359.9999… and 0 are neighbours), to a micro-degree.
        apart = (bearing - bearing_deg(*pair) + 180) % 360 - 180
        assert abs(apart) < 1e-6, pair
        assert 0 <= bearing < 360, pair
    # A known geodesic value: Greenwich to New York is 5,570 km on the mean sphere.
    assert distance_m(51.4778, -0.0015, 40.7486, -73.9864) == pytest.approx(5_570_000, rel=2e-3)


def test_a_fixed_heading_is_picked_on_the_map_and_a_light_queued_then_cancelled(
    browser, live_server, operator_user, glider: Vessel, make_fix
) -> None:
    fix_ingest(
        vessel=glider,
        records=[make_fix(time=timezone.now().isoformat(), lat=-32.0380, lon=115.3325)],
    )
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: fleet_ready(b) and "glider" in on_the_map(b))
    set_view(browser, (-32.0380, 115.3325), 14)
    open_panel(browser, "glider")
    browser.find_element(By.CSS_SELECTOR, '#fleet-panel button.action[data-kind="fhead"]').click()
    the_map = browser.find_element(By.ID, "fleet-map")
    ActionChains(browser).move_to_element_with_offset(the_map, -120, 90).click().perform()
    text = wait_for(
        browser, lambda b: b.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-text")
    ).text
    assert text.startswith("Queue “Fixed heading ") and "towards the clicked point" in text
    shot(browser, "fleet-9-fhead-confirm")
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-queue").click()
    wait_until(lambda: Command.objects.filter(kind="fhead").exists(), 20, "the fhead")
    bearing = Command.objects.get(kind="fhead").params["bearing"]
    assert 180 < bearing < 270  # down and to the left of the glider: south-west
    assert f"Fixed heading {bearing:03d}°" in text

    assert not Command.objects.get(kind="fhead").urgent
    browser.find_element(By.CSS_SELECTOR, '#fleet-panel button.action[data-kind="light"]').click()
    # Urgent: the shore also sends it by the glider's SMS or SBD link (docs/links.md).
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-urgent input").click()
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-queue").click()
    wait_until(lambda: Command.objects.filter(kind="light").exists(), 20, "the light")
    light = Command.objects.get(kind="light")
    assert light.params == {"state": "on"} and light.urgent
    line = f'#fleet-panel li[data-uid="{light.uid}"]'
    wait_for(browser, lambda b: "urgent" in b.find_element(By.CSS_SELECTOR, line).text)
    cancel = f'#fleet-panel li[data-uid="{light.uid}"] .cancel-command'
    wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, cancel).click() or True)
    wait_for(
        browser,
        lambda b: b.find_elements(
            By.CSS_SELECTOR, f'#fleet-panel li[data-uid="{light.uid}"][data-status="cancelled"]'
        ),
    )
    light.refresh_from_db()
    assert light.status == "cancelled"
    shot(browser, "fleet-10-light-cancelled")


def message(browser) -> str:
    return browser.find_element(By.CSS_SELECTOR, "#fleet-panel .action-message").text


def test_a_typed_heading_outside_0_to_359_is_refused_by_the_map_and_by_the_server(
    browser, live_server, operator_user, glider: Vessel, make_fix
) -> None:
    """Issue 16 §3: a typed 400 once wrapped to 040° and queued."""
    fix_ingest(
        vessel=glider,
        records=[make_fix(time=timezone.now().isoformat(), lat=-32.0380, lon=115.3325)],
    )
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: fleet_ready(b) and "glider" in on_the_map(b))
    open_panel(browser, "glider")
    browser.find_element(By.CSS_SELECTOR, '#fleet-panel button.action[data-kind="fhead"]').click()
    for typed in ("400", "-5", "12.5"):
        box = browser.find_element(By.CSS_SELECTOR, "#fleet-panel .bearing-input")
        box.clear()
        box.send_keys(typed)
        browser.find_element(By.CSS_SELECTOR, "#fleet-panel .use-bearing").click()
        said = f"A heading is a whole number of degrees from 0 to 359 (you typed {typed})."
        wait_for(browser, lambda b, said=said: message(b) == said)
        assert not browser.find_elements(By.CSS_SELECTOR, "#fleet-panel .confirm-queue")
        # The box keeps what was typed, to be corrected.
        box = browser.find_element(By.CSS_SELECTOR, "#fleet-panel .bearing-input")
        assert box.get_attribute("value") == typed
    shot(browser, "fleet-11-heading-400-refused")

    # The map's own send path carries the value as given: the server refuses 400 too.
    js(
        browser,
        "var f = window.shoresideFleet; f.askBearing(f.pick.action, 400, null); f.send();",
    )
    wait_for(
        browser,
        lambda b: (
            message(b) == "Not queued (HTTP 400): bearing must be between 0 and 359 (got 400)"
        ),
    )
    assert not Command.objects.exists()

    js(browser, "window.shoresideFleet.cancelPick()")
    browser.find_element(By.CSS_SELECTOR, '#fleet-panel button.action[data-kind="fhead"]').click()
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .bearing-input").send_keys("40")
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .use-bearing").click()
    confirm = browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-text").text
    assert confirm == "Queue “Fixed heading 040°” for Wave Glider?"
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-queue").click()
    wait_until(lambda: Command.objects.filter(kind="fhead").exists(), 20, "the fhead")
    command = Command.objects.get()
    assert (command.params, command.source) == ({"bearing": 40}, "map")


def test_a_far_move_to_is_warned_about_and_refused_past_the_vessels_limit(
    browser, live_server, operator_user, vessel_a: Vessel, make_fix
) -> None:
    """Issue 16 §2: a click 733 km inland was queued and the boat set off."""
    perth = (-31.9505, 115.8605)
    fix_ingest(
        vessel=vessel_a,
        records=[make_fix(time=timezone.now().isoformat(), lat=perth[0], lon=perth[1])],
    )
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: fleet_ready(b) and "spab" in on_the_map(b))
    # Zoomed out to a continent: 200 px from the boat is hundreds of kilometres.
    set_view(browser, perth, 6)
    open_panel(browser, "spab")
    browser.find_element(By.CSS_SELECTOR, '#fleet-panel button.action[data-kind="move_to"]').click()
    the_map = browser.find_element(By.ID, "fleet-map")
    ActionChains(browser).move_to_element_with_offset(the_map, 200, -150).click().perform()
    warning = wait_for(
        browser, lambda b: b.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-warning")
    ).text
    target = js(browser, "var p = window.shoresideFleet.pending.params; return [p.lat, p.lon]")
    km = distance_m(*perth, *target) / 1000
    assert km > 100
    assert warning == f"This is {km:.1f} km away — far beyond a normal move."
    shot(browser, "fleet-12-far-move-to-warned")

    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-queue").click()
    said = wait_for(browser, lambda b: message(b).startswith("Not queued") and message(b))
    assert said == (
        f"Not queued (HTTP 400): move_to target is {km:.1f} km from SPAB's last fix; "
        "the limit is 5.0 km (MOVE_TO_MAX_M)"
    )
    assert not Command.objects.exists()
    shot(browser, "fleet-13-far-move-to-refused")

    # A move of a few hundred metres: no warning, and it is queued.
    set_view(browser, perth, 16)
    js(browser, "window.shoresideFleet.cancelPick()")
    browser.find_element(By.CSS_SELECTOR, '#fleet-panel button.action[data-kind="move_to"]').click()
    ActionChains(browser).move_to_element_with_offset(the_map, 60, -40).click().perform()
    wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-text"))
    assert not browser.find_elements(By.CSS_SELECTOR, "#fleet-panel .confirm-warning")
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-queue").click()
    wait_until(lambda: Command.objects.filter(kind="move_to").exists(), 20, "the move_to")
    assert Command.objects.get().source == "map"


HOME = (-31.9800, 115.8200)


@pytest.fixture
def simulated_boat(live_server, vessel_a: Vessel, tmp_path: Path):
    """The real edge client driving the Rover simulator, as `manage.py simulate_boat` runs
    them (fast: 50 m/s, 0.3 s periods)."""
    _, key = vessel_key_issue(vessel=vessel_a, label="browser test")
    port = free_port()
    sim = start(
        ["-m", "edge_client.sim", "--listen", f"udpin:127.0.0.1:{port}",
         "--lat", str(HOME[0]), "--lon", str(HOME[1]), "--speed", "20", "--rate", "10",
         "--prearm-delay", "1", "--position-delay", "1"],
        tmp_path / "sim.log",
    )  # fmt: skip
    client = start(
        ["-m", "edge_client", "run", "--server", live_server.url, "--key", key,
         "--mavlink", f"udpout:127.0.0.1:{port}", "--outbox", str(tmp_path / "outbox.sqlite3"),
         "--telemetry-period", "0.5", "--poll-period", "0.5"],
        tmp_path / "edge.log",
    )  # fmt: skip
    try:
        yield vessel_a
    finally:
        stop(client)
        stop(sim)


def test_a_move_to_queued_from_the_map_is_carried_out_by_the_simulated_boat(
    browser, live_server, operator_user, simulated_boat: Vessel
) -> None:
    vessel = simulated_boat
    wait_until(lambda: Vessel.objects.get(pk=vessel.pk).last_fix, 30, "a first fix")
    sensor_channel_save(
        channel=SensorChannel(key="water_temp_c", label="Water temperature", unit="°C")
    )
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: fleet_ready(b) and "spab" in on_the_map(b))
    set_view(browser, HOME, 16)
    open_panel(browser, "spab")
    browser.find_element(By.CSS_SELECTOR, '#fleet-panel button.action[data-kind="move_to"]').click()
    the_map = browser.find_element(By.ID, "fleet-map")
    ActionChains(browser).move_to_element_with_offset(the_map, 80, -60).click().perform()
    confirm = wait_for(
        browser, lambda b: b.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-text")
    )
    text = confirm.text
    assert (
        text.startswith("Move SPAB to ") and " m at " in text and "from its last position" in text
    )
    shot(browser, "fleet-5-move-to-confirm")

    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-queue").click()
    wait_until(lambda: Command.objects.filter(kind="move_to").exists(), 20, "the move_to")
    command = Command.objects.get(kind="move_to")
    # The history says it came from the map (issue 16 §9), and the panel shows it.
    assert command.source == "map" and command.created_by == operator_user.username
    target = (command.params["lat"], command.params["lon"])
    fix = Vessel.objects.get(pk=vessel.pk).last_fix
    metres = distance_m(fix["lat"], fix["lon"], *target)
    bearing = bearing_deg(fix["lat"], fix["lon"], *target)
    # What the confirmation said is what the server's geometry says (the boat sat still).
    assert f"{round(metres)} m at {round(bearing) % 360:03d}°" in text

    def shown_status(b) -> str | None:
        return js(
            b,
            "var li = document.querySelector('#fleet-panel li[data-uid=\"' + arguments[0] + '\"]');"
            "return li && li.dataset.status",
            str(command.uid),
        )

    wait_for(browser, lambda b: shown_status(b) in ("sent", "acknowledged", "done"))
    shown = browser.find_element(By.CSS_SELECTOR, f'#fleet-panel li[data-uid="{command.uid}"]')
    assert f"by {operator_user.username} via map" in shown.text
    shot(browser, "fleet-6-move-to-underway")
    wait_for(browser, lambda b: shown_status(b) == "done", 60)
    command.refresh_from_db()
    assert command.status == "done"
    wait_for(browser, lambda b: "done" in b.find_element(By.ID, "fleet-panel").text)
    shot(browser, "fleet-7-move-to-done")


def test_a_command_the_boat_replaced_shows_superseded_in_grey_not_failed_red(
    browser, live_server, operator_user, simulated_boat: Vessel
) -> None:
    vessel = simulated_boat
    wait_until(lambda: Vessel.objects.get(pk=vessel.pk).last_fix, 30, "a first fix")
    vessel.refresh_from_db()  # the move_to is measured from that fix
    far = command_enqueue(vessel=vessel, kind="move_to",
                          params={"lat": HOME[0] + 0.005, "lon": HOME[1]})  # fmt: skip
    wait_until(lambda: status_of(far) == "acknowledged", 30, "the boat to set off")
    hold = command_enqueue(vessel=vessel, kind="hold", params={})  # the boat replaces the move_to
    wait_until(lambda: status_of(hold) == "done", 30, "the hold")
    far.refresh_from_db()
    assert (far.status, far.result_detail) == ("superseded", f"replaced by hold command {hold.uid}")
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: fleet_ready(b) and "spab" in on_the_map(b))
    open_panel(browser, "spab")
    selector = f'#fleet-panel li[data-uid="{far.uid}"][data-status="superseded"] .status-badge'
    badge = wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, selector))
    grey = ("rgb(117, 117, 117)", "rgba(117, 117, 117, 1)")  # maps.css .cmd-superseded
    assert badge.value_of_css_property("background-color") in grey
    shot(browser, "fleet-8-superseded-grey")


def status_of(command: Command) -> str:
    command.refresh_from_db(fields=["status"])
    return command.status


def test_the_fleet_map_draws_without_a_reachable_tile_server(
    browser, live_server, operator_user, vessel_a: Vessel, make_fix, settings
) -> None:
    settings.MAP_TILES_URL = "http://127.0.0.1:9/{z}/{x}/{y}.png"  # nothing listens there
    fix_ingest(vessel=vessel_a, records=[make_fix(time=timezone.now().isoformat())])
    log_in(browser, live_server, operator_user)
    wait_for(browser, lambda b: fleet_ready(b) and "spab" in on_the_map(b))
    # Tried them, then gave up on them for the offline coastline (tests/browser/test_coastline.py).
    wait_for(
        browser,
        lambda b: b.find_element(By.ID, "fleet-map").get_attribute("data-base") == "coastline",
    )
    assert browser.find_elements(By.CSS_SELECTOR, "#fleet-map .graticule-label")
    assert browser.find_elements(By.CSS_SELECTOR, "#fleet-map .leaflet-control-scale")
    shot(browser, "fleet-8-unreachable-tiles")
