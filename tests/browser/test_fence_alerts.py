"""Fences and alerts in a real browser (issue 19): an operator draws a fence on the admin's
map (Leaflet.draw), sees it on the fleet map, sees an alert open when the simulated boat sails
out of it (a red badge on the boat and in the list) and acknowledges it from the boat's panel."""

from __future__ import annotations

import datetime as dt

import pytest
from django.core.management import call_command
from django.utils import timezone
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

from alerts.models import Alert, AlertRule, AlertState
from alerts.services.rules import alert_rule_create
from commands.services import command_enqueue
from edge_client.contract.geo import offset
from tests.alerts.conftest import ALERT_PERMS
from tests.browser.support import js, log_in, set_view, shot, wait_for
from tests.browser.test_fleet_map import (
    HOME,
    fleet_ready,
    on_the_map,
    simulated_boat,  # noqa: F401 (a fixture)
)
from tests.conftest import make_user
from tests.edge_client.helpers import wait_until
from vessels.models import Fence, Vessel

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]


@pytest.fixture(autouse=True)
def _fast_polls(settings) -> None:
    settings.FLEET_MAP_POLL_S = 1
    settings.FLEET_MAP_TRAIL_REFRESH_S = 5


@pytest.fixture
def watch_operator(db):
    return make_user("carol", [*ALERT_PERMS, "vessels.change_vessel"])


def corners(centre: tuple[float, float], half_m: float) -> list[tuple[float, float]]:
    """A square's corners (lat, lon), ``half_m`` from ``centre`` each way: NE, SE, SW, NW."""
    north = offset(*centre, 0, half_m)[0]
    south = offset(*centre, 180, half_m)[0]
    east = offset(*centre, 90, half_m)[1]
    west = offset(*centre, 270, half_m)[1]
    return [(north, east), (south, east), (south, west), (north, west)]


def click_at(browser, element_id: str, lat: float, lon: float, map_js: str) -> None:
    """Click the map where (lat, lon) is (Selenium's offsets are from the element's centre)."""
    x, y, w, h = js(
        browser,
        f"var m = {map_js}, p = m.latLngToContainerPoint([arguments[0], arguments[1]]),"
        " s = m.getSize(); return [p.x, p.y, s.x, s.y];",
        lat,
        lon,
    )
    the_map = browser.find_element(By.ID, element_id)
    ActionChains(browser).move_to_element_with_offset(the_map, x - w / 2, y - h / 2).pause(
        0.2
    ).click().perform()


def draw_fence(browser, live_server, vessel: Vessel, square: list[tuple[float, float]]) -> Fence:
    """Draw ``square`` with the polygon tool on the fence's admin page and save it."""
    browser.get(live_server.url + "/admin/vessels/fence/add/")
    wait_for(browser, lambda b: js(b, "return !!window.shoresideFenceEditor"))
    editor = "window.shoresideFenceEditor.map"
    set_view(browser, HOME, 16, editor)
    browser.find_element(By.NAME, "name").send_keys("Harbour box")
    browser.find_element(
        By.CSS_SELECTOR, f'select[name=vessel] option[value="{vessel.pk}"]'
    ).click()
    browser.find_element(By.CSS_SELECTOR, "a.leaflet-draw-draw-polygon").click()
    for lat, lon in [*square, square[0]]:  # the first corner again closes the ring
        click_at(browser, "fence-map", lat, lon, editor)
    wait_for(browser, lambda b: b.find_element(By.NAME, "geometry").get_attribute("value"))
    shot(browser, "fence-1-drawn")
    browser.find_element(By.NAME, "_save").click()
    wait_until(lambda: Fence.objects.exists(), 20, "the fence saved")
    return Fence.objects.get()


def assert_drawn_as(fence: Fence, square: list[tuple[float, float]]) -> None:
    """The stored ring is the square clicked, closed, to within a pixel (~2.4 m at zoom 16)."""
    ring = fence.geometry["coordinates"][0]
    assert fence.geometry["type"] == "Polygon" and len(ring) == 5 and ring[0] == ring[-1]
    for (lon, lat), (want_lat, want_lon) in zip(ring, square, strict=False):
        assert abs(lat - want_lat) < 5e-5 and abs(lon - want_lon) < 5e-5


def badge(browser, where: str) -> str | None:
    return js(
        browser,
        "var b = document.querySelector(arguments[0]); return b && b.dataset.count",
        f'{where}[data-slug="spab"] .alert-badge.alert-open',
    )


def acknowledge_from_the_panel(browser, alert: Alert) -> None:
    browser.find_element(By.CSS_SELECTOR, '#fleet-panel tr[data-slug="spab"]').click()
    button = wait_for(
        browser,
        lambda b: b.find_element(
            By.CSS_SELECTOR, f'#fleet-panel li[data-id="{alert.pk}"] button.ack-alert'
        ),
    )
    shot(browser, "fence-3-alert-in-panel")
    button.click()
    wait_until(
        lambda: Alert.objects.get(pk=alert.pk).state == AlertState.ACKNOWLEDGED, 20, "the ack"
    )
    selector = f'#fleet-panel li[data-id="{alert.pk}"][data-state="acknowledged"]'
    wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, selector))
    # The red badge gives way to an orange one: acknowledged, still active.
    wait_for(browser, lambda b: badge(b, "#fleet-map .vessel-icon") is None)
    assert browser.find_elements(
        By.CSS_SELECTOR, '#fleet-map .vessel-icon[data-slug="spab"] .alert-badge.alert-acknowledged'
    )
    shot(browser, "fence-4-acknowledged")
    # The vessel's own page lists it too (acknowledged, by whom) beside its battery endurance.
    vessel = Alert.objects.get(pk=alert.pk).vessel
    browser.get(
        f"{browser.current_url.split('/admin/')[0]}/admin/vessels/vessel/{vessel.pk}/change/"
    )
    page = wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, "table.open-alerts")).text
    assert "acknowledged" in page and alert.rule.name in page
    assert "not enough history yet" in browser.find_element(By.TAG_NAME, "body").text
    browser.execute_script(
        "document.querySelector('table.open-alerts').scrollIntoView({block: 'center'})"
    )
    shot(browser, "fence-5-vessel-page")


def test_draw_a_fence_the_boat_leaves_it_an_alert_opens_and_is_acknowledged(
    browser,
    live_server,
    watch_operator,
    simulated_boat: Vessel,  # noqa: F811 (the fixture)
) -> None:
    vessel = simulated_boat
    wait_until(lambda: Vessel.objects.get(pk=vessel.pk).last_fix, 30, "a first fix")
    vessel.refresh_from_db()
    here = (vessel.last_fix["lat"], vessel.last_fix["lon"])
    square = corners(here, 150)
    log_in(browser, live_server, watch_operator)
    fence = draw_fence(browser, live_server, vessel, square)
    assert_drawn_as(fence, square)
    rule = alert_rule_create(
        fields={"name": "Left the harbour", "kind": "fence", "fence": fence, "vessel": vessel}
    )
    call_command("run_alerts", "--once")  # inside: nothing opens
    assert not Alert.objects.exists()

    # Out of the box: 400 m north, through its northern side.
    target = offset(*here, 0, 400)
    command_enqueue(vessel=vessel, kind="move_to", params={"lat": target[0], "lon": target[1]})
    wait_until(
        lambda: Vessel.objects.get(pk=vessel.pk).last_fix["lat"] > square[0][0] + 0.0005,
        60,
        "the boat out of the fence",
    )
    call_command("run_alerts", "--once")
    alert = Alert.objects.get(rule=rule)
    assert (alert.vessel, alert.state) == (vessel, AlertState.OPEN)

    browser.get(live_server.url + "/admin/")
    wait_for(browser, lambda b: fleet_ready(b) and "spab" in on_the_map(b))
    assert browser.find_elements(By.CSS_SELECTOR, f'#fleet-map path.fence[data-fence="{fence.pk}"]')
    wait_for(browser, lambda b: badge(b, "#fleet-map .vessel-icon") == "1")
    wait_for(browser, lambda b: badge(b, "#fleet-panel tr") == "1")
    shot(browser, "fence-2-alert-on-the-map")
    acknowledge_from_the_panel(browser, alert)


def test_a_drawn_fence_shows_on_the_fleet_map_with_its_vessels_open_alert(
    browser, live_server, watch_operator, vessel_a: Vessel
) -> None:
    """The map's part of the story alone, with no boat to wait for: an alert opened (as the
    evaluator opens one) on a vessel inside a fence drawn in the browser is badged, shown and
    acknowledged."""
    from telemetry.services import fix_ingest

    now = timezone.now()
    fix_ingest(vessel=vessel_a, records=[{"time": now.isoformat(), "lat": HOME[0], "lon": HOME[1]}])
    square = corners(HOME, 150)
    log_in(browser, live_server, watch_operator)
    fence = draw_fence(browser, live_server, vessel_a, square)
    assert_drawn_as(fence, square)
    rule = AlertRule.objects.create(name="Left the harbour", kind="fence", fence=fence)
    alert = Alert.objects.create(
        rule=rule, vessel=vessel_a, kind="fence", opened_at=now - dt.timedelta(minutes=2),
        detail="outside Harbour box",
    )  # fmt: skip

    browser.get(live_server.url + "/admin/")
    wait_for(browser, lambda b: fleet_ready(b) and "spab" in on_the_map(b))
    wait_for(
        browser,
        lambda b: b.find_elements(
            By.CSS_SELECTOR, f'#fleet-map path.fence[data-fence="{fence.pk}"]'
        ),
    )
    wait_for(browser, lambda b: badge(b, "#fleet-map .vessel-icon") == "1")
    wait_for(browser, lambda b: badge(b, "#fleet-panel tr") == "1")
    shot(browser, "fence-2-alert-on-the-map")
    acknowledge_from_the_panel(browser, alert)
    assert Alert.objects.get().acknowledged_by == "carol"
