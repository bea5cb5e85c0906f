"""An operator imports a Mission Planner file in a real browser and lands on the mission."""

from __future__ import annotations

from pathlib import Path

import pytest
from django.contrib.auth.models import User
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select, WebDriverWait

from tests.browser.test_admin_in_browser import log_in, shot
from vessels.models import Mission, Vessel

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]
FILES = Path(__file__).parents[1] / "vessels" / "files"


def test_an_operator_imports_a_waypoints_file_for_a_vessel(
    browser, live_server, admin_user: User, vessel_a: Vessel
) -> None:
    admin_user.set_password("pw-" + admin_user.username)
    admin_user.save()
    log_in(browser, live_server, admin_user)
    browser.get(live_server.url + "/admin/vessels/mission/")
    browser.find_element(By.CSS_SELECTOR, 'a[href$="/mission/import/"]').click()
    browser.find_element(By.NAME, "file").send_keys(str(FILES / "survey.plan"))
    Select(browser.find_element(By.NAME, "vessel")).select_by_visible_text("SPAB")
    shot(browser, "mission-import")
    browser.find_element(By.CSS_SELECTOR, "#mission-import input[type=submit]").click()
    WebDriverWait(browser, 20).until(lambda b: "item 4 (ComplexItem survey)" in b.page_source)
    shot(browser, "mission-import-refused")
    assert not Mission.objects.exists()

    browser.find_element(By.NAME, "file").send_keys(str(FILES / "survey.plan"))
    browser.find_element(By.NAME, "skip_unsupported").click()
    browser.find_element(By.CSS_SELECTOR, "#mission-import input[type=submit]").click()
    WebDriverWait(browser, 20).until(lambda b: "/change/" in b.current_url)
    page = browser.page_source
    assert "Imported survey: 3 waypoint(s)." in page
    assert "Skipped item 4 (ComplexItem survey)" in page
    assert browser.find_element(By.ID, "mission-route").is_displayed()
    shot(browser, "mission-page")
    route = browser.find_element(By.ID, "mission-route")
    browser.execute_script("arguments[0].scrollIntoView()", route)
    shot(browser, "mission-route")
    mission = Mission.objects.get()
    assert (mission.vessel, mission.end, mission.items.count()) == (vessel_a, "return_home", 3)
