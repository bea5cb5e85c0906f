"""An operator in a real browser: log in, see the fleet, queue a command with the kind form."""

from __future__ import annotations

import pytest
from django.contrib.auth.models import User
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select, WebDriverWait

from commands.models import Command
from telemetry.services import fix_ingest
from tests.browser.support import log_in, shot
from tests.conftest import OPERATOR_PERMS, make_user
from vessels.models import Mission, Vessel
from vessels.services import mission_save, mission_save_items

# A real chromium per test: not for the quick loop.
pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]


def visible(browser, name: str) -> bool:
    return browser.find_element(By.NAME, name).is_displayed()


def test_an_operator_logs_in_and_queues_a_move_to(
    browser, live_server, operator_user: User, vessel_a: Vessel, make_fix
) -> None:
    fix_ingest(vessel=vessel_a, records=[make_fix()])
    log_in(browser, live_server, operator_user)
    browser.get(live_server.url + "/admin/vessels/vessel/")
    assert "SPAB" in browser.page_source and "-31.95050°, 115.86050°" in browser.page_source
    shot(browser, "vessel-list")

    browser.get(live_server.url + f"/admin/commands/command/add/?vessel={vessel_a.pk}")
    kind = Select(browser.find_element(By.NAME, "kind"))
    kind.select_by_value("fhead")
    assert visible(browser, "fhead__bearing") and not visible(browser, "move_to__lat")
    kind.select_by_value("move_to")
    assert visible(browser, "move_to__lat") and not visible(browser, "fhead__bearing")
    browser.find_element(By.NAME, "move_to__lat").send_keys("-31.96")
    browser.find_element(By.NAME, "move_to__lon").send_keys("115.85")
    shot(browser, "command-form")
    browser.find_element(By.NAME, "_save").click()
    # Wait for the answer before reading the database (Command.objects.get() raced the POST).
    WebDriverWait(browser, 20).until(lambda b: "/add/" not in b.current_url)

    command = Command.objects.get()
    assert (command.vessel, command.kind, command.params) == (
        vessel_a,
        "move_to",
        {"lat": -31.96, "lon": 115.85},
    )
    assert command.created_by == operator_user.username
    assert "was added successfully" in browser.page_source


def test_the_admin_loads_no_asset_from_the_internet(
    browser, live_server, admin_user: User, vessel_a: Vessel
) -> None:
    admin_user.set_password("pw-admin")
    admin_user.save()
    log_in(browser, live_server, admin_user)
    pages = (
        "/admin/",  # the fleet map
        f"/fleet/vessels/{vessel_a.slug}/track/",
        "/admin/vessels/mission/add/",  # the planner
        "/admin/commands/command/add/",
        "/api/v1/docs/",
    )
    for path in pages:
        browser.get(live_server.url + path)
        urls = browser.execute_script(
            "return performance.getEntriesByType('resource').map(e => e.name)"
        )
        outside = [u for u in urls if not u.startswith(live_server.url)]
        assert outside == [], path
    assert "swagger-ui" in browser.page_source


def test_the_mission_lists_send_asks_with_each_summary_before_anything_is_queued(
    browser, live_server, vessel_a: Vessel, make_fix
) -> None:
    operator_user = make_user(
        "mia", [*OPERATOR_PERMS, "vessels.view_mission", "vessels.change_mission"]
    )

    fix_ingest(vessel=vessel_a, records=[make_fix()])
    mission = mission_save(mission=Mission(name="Bay", vessel=vessel_a))
    mission_save_items(mission=mission, items=[{"lat": -31.9505, "lon": 115.8705}])
    log_in(browser, live_server, operator_user)
    browser.get(live_server.url + "/admin/vessels/mission/")
    browser.find_element(
        By.CSS_SELECTOR, f'input[name="_selected_action"][value="{mission.pk}"]'
    ).click()
    Select(browser.find_element(By.NAME, "action")).select_by_value("send_to_vessel")
    browser.find_element(By.NAME, "index").click()
    WebDriverWait(browser, 20).until(lambda b: "Send these missions?" in b.page_source)
    summary = browser.find_element(By.CSS_SELECTOR, "ul.send-summaries").text
    assert summary.startswith("Bay: Send to SPAB: 1 waypoint")
    assert not Command.objects.exists()
    shot(browser, "mission-list-send-confirm")
    browser.find_element(By.CSS_SELECTOR, 'input[type=submit][value="Yes, send them"]').click()
    WebDriverWait(browser, 20).until(lambda b: "queued as command" in b.page_source)
    assert Command.objects.get().kind == "mission"
