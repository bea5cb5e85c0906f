"""The fleet map's page weight (issue 18 §1: ≤ 1.5 MB of static assets with the coastline).

    python -m bench.page_weight

A throwaway site as an operator would run it at sea: a fresh data folder, collectstatic
(hashed names and gzip copies), the demo fleet, MAP_TILES_URL empty, gunicorn with WhiteNoise.
Debian's chromium (headless) logs in and opens the fleet map; the browser's Resource Timing says
what each static file cost: "wire" is what came over the network (gzip body and headers; 0
when the browser had it cached, e.g. the admin's CSS from the login page), "gzip body" the file
as served gzipped, "unpacked" its size; a first load costs the gzip body column plus headers.
Then the same map at zoom 11 off Fremantle, zoomed out to 4 and 1, a second visit (what the
browser's cache saves) and the track page (uPlot). Prints a table per step; nothing is asserted.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable
PASSWORD = "pw-page-weight"
VIEWS = [("zoom 11 off Fremantle", (-32.03, 115.62), 11), ("zoom 4", (-30.0, 120.0), 4)]
VIEWS.append(("zoom 1", (0.0, 0.0), 1))

ENTRIES = """return performance.getEntriesByType('resource')
  .filter(e => e.name.indexOf('/static/') >= 0)
  .map(e => [e.name, e.transferSize, e.encodedBodySize, e.decodedBodySize])"""


PAGE = "var n = performance.getEntriesByType('navigation')[0]; return [n.transferSize]"


def run(args: list[str], env: dict[str, str]) -> None:
    subprocess.run([PY, "manage.py", *args], cwd=ROOT, env=env, check=True)


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def browser() -> Any:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = os.environ.get("CHROMIUM", "/usr/bin/chromium")
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                 "--disable-background-networking", "--window-size=1280,900"):  # fmt: skip
        options.add_argument(flag)
    service = Service(os.environ.get("CHROMEDRIVER", "/usr/bin/chromedriver"))
    return webdriver.Chrome(service=service, options=options)


def wait(driver: Any, script: str, timeout: float = 60) -> None:
    end = time.monotonic() + timeout
    while not driver.execute_script(script):
        if time.monotonic() > end:
            raise SystemExit(f"timed out waiting for: {script}")
        time.sleep(0.2)


def settled(driver: Any) -> None:
    """The coastline drew every cell it wanted at the zoom in view."""
    wait(driver, "var c = window.Shoreside.maps['fleet-map'].coastline; return c && c.settled()")


def report(title: str, entries: list[list[Any]], seen: set[str]) -> None:
    new = [e for e in entries if e[0] not in seen]
    seen.update(e[0] for e in new)
    print(f"\n{title}: {len(new)} static file(s)")
    print(f"  {'wire':>9} {'gzip body':>10} {'unpacked':>10}  file")
    for name, wire, body, unpacked in sorted(new, key=lambda e: -e[3]):
        short = name.split("/static/", 1)[1]
        print(f"  {wire:>9,} {body:>10,} {unpacked:>10,}  {short}")
    totals = [sum(e[i] for e in new) for i in (1, 2, 3)]
    print(f"  {totals[0]:>9,} {totals[1]:>10,} {totals[2]:>10,}  total")


def main() -> None:
    data = Path(tempfile.mkdtemp(prefix="shoreside-weight-"))
    env = {**os.environ, "SHORESIDE_DATA_DIR": str(data), "WHITENOISE_USE_FINDERS": "0",
           "MAP_TILES_URL": "", "DEBUG": "0"}  # fmt: skip
    server = driver = None
    try:
        run(["migrate", "--noinput", "-v0"], env)
        run(["collectstatic", "--noinput", "-v0"], env)
        run(["seed_demo", "--password", PASSWORD, "--keys-file", str(data / "keys.json")], env)
        port = free_port()
        server = subprocess.Popen(
            [PY, "-m", "gunicorn", "fleet.wsgi", "-b", f"127.0.0.1:{port}", "-w", "1"],
            cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        url = f"http://127.0.0.1:{port}"
        driver = browser()
        for _ in range(100):
            try:
                driver.get(url + "/admin/login/")
                driver.find_element("name", "username")
                break
            except Exception:
                time.sleep(0.3)
        driver.find_element("name", "username").send_keys("operator")
        driver.find_element("name", "password").send_keys(PASSWORD)
        driver.find_element("css selector", "input[type=submit]").click()
        wait(driver, "return !!(window.shoresideFleet && window.shoresideFleet.fitted)")
        settled(driver)
        seen: set[str] = set()
        zoom = driver.execute_script("return window.shoresideFleet.map.getZoom()")
        report(f"first load, default view (fitted to the demo fleet, zoom {zoom})",
               driver.execute_script(ENTRIES), seen)  # fmt: skip
        for title, (lat, lon), z in VIEWS:
            driver.execute_script(
                f"window.Shoreside.maps['fleet-map'].map.setView([{lat}, {lon}], {z}, "
                "{animate: false})"
            )
            settled(driver)
            report(f"then {title}: what more it fetched", driver.execute_script(ENTRIES), seen)
        # A first load straight at zoom 11 off Fremantle: the default view's cells are that
        # view's too (the demo fleet is off Fremantle), so the first table is that load.
        driver.get(url + "/admin/")
        wait(driver, "return !!(window.shoresideFleet && window.shoresideFleet.fitted)")
        settled(driver)
        report("second visit (browser cache): what it fetched again",
               driver.execute_script(ENTRIES), set())  # fmt: skip
        html = driver.execute_script(PAGE)
        print(f"\n(the page itself, not counted above: {html[0]:,} bytes on the wire)")
        driver.get(url + "/fleet/vessels/spab/track/")
        wait(driver, "return document.querySelectorAll('#plots .plot').length > 0")
        report("then the track page (uPlot): what more it fetched",
               driver.execute_script(ENTRIES), seen)  # fmt: skip
    finally:
        if driver is not None:
            driver.quit()
        if server is not None:
            server.terminate()
            server.wait(10)
        shutil.rmtree(data, ignore_errors=True)


if __name__ == "__main__":
    main()
