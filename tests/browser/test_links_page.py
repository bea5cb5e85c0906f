"""The vessel's page in a browser: the Links block (what each transport carried and cost) and
its budgets, as an operator sees them (issue 20 §4)."""

from __future__ import annotations

import datetime as dt

from django.utils import timezone
from selenium.webdriver.common.by import By

from links.services import link_count
from tests.browser.support import log_in, shot, wait_for
from vessels.services import vessel_create


def test_the_vessel_page_shows_what_each_link_cost(browser, live_server, operator_user) -> None:
    vessel = vessel_create(slug="sat-1", name="Sat 1", kind="mavlink")
    now = timezone.now()
    link_count(vessel_id=vessel.pk, transport="sbd", at=now - dt.timedelta(minutes=7),
               contact=True, messages_in=1, bytes_in=240, credits=5, fixes_in=60)  # fmt: skip
    link_count(vessel_id=vessel.pk, transport="http", at=now, contact=True, messages_in=360,
               messages_out=360, bytes_in=138_000, bytes_out=79_000, fixes_in=1800)  # fmt: skip
    log_in(browser, live_server, operator_user)
    browser.get(f"{live_server.url}/admin/vessels/vessel/{vessel.pk}/change/")
    table = wait_for(browser, lambda b: b.find_element(By.CSS_SELECTOR, "table.links"))
    rows = {r.get_attribute("class"): r.text for r in table.find_elements(By.TAG_NAME, "tr")}
    assert rows["link-sbd"].startswith("Iridium SBD 7 min ago")
    assert rows["link-sbd"].endswith("4.0 B (60 fixes)")
    assert rows["link-http"].endswith("76.7 B (1800 fixes)")
    assert rows["link-sms"].startswith("SMS never")
    # Alice may view vessels, not change them: the budgets show, read-only.
    assert "SBD credits a day" in browser.find_element(By.TAG_NAME, "body").text
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", table)
    shot(browser, "links-1-vessel-page")
