"""The SMS log in a real browser (headless chromium), as an operator sees it."""

from __future__ import annotations

import datetime as dt

import pytest
from selenium.webdriver.common.by import By

from sms.models import SmsMessage
from sms.services import authorised_number_authorise, sms_handle_incoming
from tests.browser.conftest import browser  # noqa: F401  (the fixture)
from tests.browser.test_admin_in_browser import log_in, shot
from tests.conftest import make_user
from tests.support import BASE
from vessels.models import Vessel

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.django_db(transaction=True)]


def test_an_operator_reads_the_sms_log(browser, live_server, glider: Vessel) -> None:  # noqa: F811
    operator = make_user("carol", ["sms.view_smsmessage", "commands.view_command"])
    authorised_number_authorise(
        number="+61412345678", vessels=[glider], role="control", name="Skipper"
    )
    texts = ["#FHEAD 230", "#WAYPOINT 1 32 02.28S 115 19.95E\n#FSEQ 1 1 4", "#STATUS"]
    for i, text in enumerate(texts):
        sms_handle_incoming(
            vessel=glider, number="0412 345 678", text=text,
            received_at=BASE + dt.timedelta(minutes=i),
        )  # fmt: skip
    sms_handle_incoming(vessel=glider, number="+61400000001", text="hello", received_at=BASE)
    log_in(browser, live_server, operator)
    browser.get(live_server.url + "/admin/sms/smsmessage/")
    rows = browser.find_elements(By.CSS_SELECTOR, "#result_list tbody tr")
    assert len(rows) == 7  # four in, three replies (none to the stranger)
    page = browser.page_source
    assert "#FSEQ 1 1 4 ERR not enabled on this glider" in page
    assert "stranger" in page
    shot(browser, "sms-log")

    waypoint = SmsMessage.objects.get(direction="in", text__startswith="#WAYPOINT")
    browser.get(live_server.url + f"/admin/sms/smsmessage/{waypoint.pk}/change/")
    page = browser.page_source
    assert "#WAYPOINT 1 -32.0380 115.3325 QUEUED" in page  # its reply, inline
    assert "/admin/commands/command/" in page  # the command it created
    shot(browser, "sms-message")
