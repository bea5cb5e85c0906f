"""Steps every browser test takes: log in, wait for the page's scripts, save a screenshot."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from django.contrib.auth.models import User
from selenium.common.exceptions import NoSuchElementException, StaleElementReferenceException
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

from tests.browser.conftest import SCREENSHOTS

WAIT_S = 30  # generous: six engineers share two cores


def shot(browser: Any, name: str) -> None:
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    browser.save_screenshot(str(SCREENSHOTS / f"{name}.png"))


def log_in(browser: Any, live_server: Any, user: User) -> None:
    browser.get(live_server.url + "/admin/login/")
    browser.find_element(By.NAME, "username").send_keys(user.username)
    browser.find_element(By.NAME, "password").send_keys("pw-" + user.username)
    browser.find_element(By.CSS_SELECTOR, "input[type=submit]").click()
    # click() may return before the POST is answered; under load the next get() raced it.
    WebDriverWait(browser, 20).until(lambda b: "/admin/login/" not in b.current_url)


# The pages redraw their lists as data arrives: an element found a moment ago may be gone.
RETRIED = (NoSuchElementException, StaleElementReferenceException)


def wait_for(browser: Any, predicate: Callable[[Any], Any], timeout: float = WAIT_S) -> Any:
    return WebDriverWait(browser, timeout, ignored_exceptions=RETRIED).until(predicate)


def js(browser: Any, script: str, *args: Any) -> Any:
    return browser.execute_script(script, *args)


FLEET_MAP = "window.shoresideFleet.map"


def set_view(
    browser: Any, centre: tuple[float, float], zoom: int, leaflet_map: str = FLEET_MAP
) -> None:
    """Move a page's map, again until it took: Leaflet drops a view set while it animates."""
    script = (
        f"var m = {leaflet_map}; m.setView(arguments[0], arguments[1], {{animate: false}});"
        "return m.getZoom() === arguments[1];"
    )
    wait_for(browser, lambda b: js(b, script, list(centre), zoom))
