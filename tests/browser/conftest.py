"""A real headless browser: Debian's chromium driven through chromedriver (selenium)."""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("CHROMEDRIVER", "/usr/bin/chromedriver")


def _chromium(env: dict[str, str] | None = None) -> Iterator[object]:
    """A headless chromium under chromedriver; ``env`` adds to the browser's environment."""
    if not (shutil.which(CHROMIUM) and shutil.which(CHROMEDRIVER)):
        message = "needs Debian's chromium and chromium-driver (apt-get install, see .ci/run)"
        if os.environ.get("SHORESIDE_REQUIRE_BROWSER") == "1":
            pytest.fail(message)
        pytest.skip(message)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    profile = tempfile.mkdtemp(prefix="shoreside-chromium-")
    # No background traffic: the machine (and a boat-side server at sea) has no internet.
    for flag in (
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-sync",
        "--disable-component-update",
        "--window-size=1280,900",
        f"--user-data-dir={profile}",
    ):
        options.add_argument(flag)
    service = Service(CHROMEDRIVER, env={**os.environ, **env} if env else None)
    driver = webdriver.Chrome(service=service, options=options)
    driver.implicitly_wait(5)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


@pytest.fixture(scope="session")
def browser() -> Iterator[object]:
    yield from _chromium()


# An operator in Western Australia: the browser's clock is UTC+8 (no daylight saving), so a
# page that let the browser's time zone in shows times eight hours off.
PERTH = "Australia/Perth"


@pytest.fixture(scope="session")
def perth_browser() -> Iterator[object]:
    yield from _chromium({"TZ": PERTH})


# Screenshots of every step are test artifacts: what an operator sees. SHORESIDE_SCREENSHOTS
# chooses the folder (CI uploads it); the run's summary prints where they went.
SCREENSHOTS = Path(
    os.environ.get("SHORESIDE_SCREENSHOTS") or Path(tempfile.gettempdir()) / "shoreside-screenshots"
)


SESSION_START = time.time()


def pytest_terminal_summary(terminalreporter: Any) -> None:
    taken = [p for p in SCREENSHOTS.glob("*.png") if p.stat().st_mtime >= SESSION_START]
    if taken:
        terminalreporter.write_line(f"browser screenshots ({len(taken)}): {SCREENSHOTS}")


@pytest.fixture(autouse=True)
def _no_map_tiles(settings: Any) -> None:
    # No internet here (nor at sea): the maps draw on a plain background, which is what the
    # tests check; a test that wants a tile URL sets its own.
    settings.MAP_TILES_URL = ""
