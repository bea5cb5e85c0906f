"""The live demo in a real browser: `bash scripts/demo.sh` running, an operator logs in with the
login it printed and gives its Wave Glider a fixed heading from the fleet map; the glider's
bridge hands it to the simulated C&C box, and the map shows it done."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from selenium.webdriver.common.by import By

from tests.browser.support import js, set_view, shot, wait_for
from tests.fleet.demo_script import Demo

pytestmark = [pytest.mark.browser, pytest.mark.slow]

DONE_S = 120  # the glider's shore poll, one C&C poll period, the acks back: seconds, not minutes


@pytest.fixture
def demo() -> Iterator[Demo]:
    run = Demo()
    try:
        run.ready()
        yield run
    finally:
        run.close()


def glider_on_the_map(browser) -> bool:
    return bool(
        js(browser, "return !!(window.shoresideFleet && window.shoresideFleet.fitted)")
        and browser.find_elements(By.CSS_SELECTOR, '#fleet-map .vessel-icon[data-slug="glider"]')
    )


def live_fix(browser) -> dict | None:
    """The glider's last fix as the map has it, if it is under a minute old (a live one)."""
    return js(
        browser,
        "var v = window.shoresideFleet.vessels.glider, f = v && v.last_fix;"
        "return f && Date.now() - Date.parse(f.time) < 60000 ? f : null;",
    )


def test_the_live_demo_glider_takes_a_fixed_heading_from_the_map(browser, demo: Demo) -> None:
    browser.get(demo.url)
    browser.find_element(By.NAME, "username").send_keys(demo.user)
    browser.find_element(By.NAME, "password").send_keys(demo.password)
    browser.find_element(By.CSS_SELECTOR, "input[type=submit]").click()
    wait_for(browser, glider_on_the_map, 60)
    # The seeded track ends minutes ago; the live glider's bridge reports within seconds.
    first = wait_for(browser, live_fix, 90)
    set_view(browser, (-32.08, 115.70), 15)
    browser.find_element(By.CSS_SELECTOR, '#fleet-map .vessel-icon[data-slug="glider"]').click()
    wait_for(browser, lambda b: "Wave Glider" in b.find_element(By.ID, "fleet-panel").text)

    browser.find_element(By.CSS_SELECTOR, '#fleet-panel button.action[data-kind="fhead"]').click()
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .bearing-input").send_keys("120")
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .use-bearing").click()
    confirm = browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-text").text
    assert confirm == "Queue “Fixed heading 120°” for Wave Glider?"
    browser.find_element(By.CSS_SELECTOR, "#fleet-panel .confirm-queue").click()

    item = '#fleet-panel li[data-status="{}"]'
    wait_for(browser, lambda b: b.find_elements(By.CSS_SELECTOR, item.format("queued")), 30)
    shot(browser, "demo-glider-1-fhead-queued")
    done = wait_for(
        browser, lambda b: b.find_elements(By.CSS_SELECTOR, item.format("done")), DONE_S
    )[0]
    assert "fhead" in done.text and "bearing 120" in done.text
    assert "via map" in done.text and "C&C: ACK (accepted)" in done.text
    # The map follows the glider as it reports: a newer fix, somewhere else.
    moved = wait_for(browser, lambda b: (f := live_fix(b)) and f["time"] > first["time"] and f, 60)
    assert (moved["lat"], moved["lon"]) != (first["lat"], first["lon"])
    shot(browser, "demo-glider-2-fhead-done")
    # The C&C box carried it out: the simulated glider turned to 120°.
    log = (demo.data / "sim-glider.log").read_text()
    assert "C&C glider: following heading 120°" in log
