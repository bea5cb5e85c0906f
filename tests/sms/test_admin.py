"""The SMS admin pages: authorised numbers edited through the service, the read-only SMS log,
and each command's page naming the SMS that created it (fleet.admin)."""

from __future__ import annotations

import re
from typing import Any

import pytest
from django.test import Client

from commands.models import Command
from sms.models import AuthorisedNumber, SmsMessage
from sms.services import authorised_number_authorise, sms_handle_incoming
from tests.support import BASE
from vessels.display import fmt_time
from vessels.models import Vessel

SKIPPER = "+61412345678"


@pytest.fixture
def traffic(glider: Vessel) -> Any:
    authorised_number_authorise(number=SKIPPER, vessels=[glider], role="control", name="Skipper")
    sms_handle_incoming(vessel=glider, number="+61400000001", text="hello?", received_at=BASE)
    return sms_handle_incoming(
        vessel=glider, number="0412 345 678", text="#FHEAD 230; #RUDDER 45", received_at=BASE
    )


def test_the_sms_log_lists_every_message_in_and_out(admin_client: Client, traffic: Any) -> None:
    page = admin_client.get("/admin/sms/smsmessage/")
    assert page.status_code == 200
    html = page.content.decode()
    assert "#FHEAD 230; #RUDDER 45" in html
    assert "#FHEAD 230 QUEUED; #RUDDER 45 ERR angle must be between -30 and 30 (got 45)" in html
    assert "hello?" in html and "stranger" in html
    assert "Add SMS message" not in html  # read-only


@pytest.mark.parametrize(
    ("query", "shown", "hidden"),
    [
        ("?direction__exact=out", "QUEUED", "hello?"),
        ("?outcome__exact=stranger", "hello?", "QUEUED"),
        ("?q=%2B61400000001", "hello?", "QUEUED"),
        ("?q=RUDDER", "QUEUED", "hello?"),
    ],
)
def test_the_sms_log_filters_and_searches(
    admin_client: Client, traffic: Any, query: str, shown: str, hidden: str
) -> None:
    html = admin_client.get("/admin/sms/smsmessage/" + query).content.decode()
    assert shown in html and hidden not in html


def test_a_message_page_links_its_commands_and_replies(admin_client: Client, traffic: Any) -> None:
    command = Command.objects.get()
    html = admin_client.get(f"/admin/sms/smsmessage/{traffic.message.pk}/change/").content.decode()
    assert f"/admin/commands/command/{command.pk}/change/" in html
    assert "#FHEAD 230 QUEUED" in html  # the reply, inline
    assert "angle must be between -30 and 30" in html  # the parsed parts


def test_a_command_page_shows_the_sms_that_created_it(admin_client: Client, traffic: Any) -> None:
    command = Command.objects.get()
    html = admin_client.get(f"/admin/commands/command/{command.pk}/change/").content.decode()
    assert "Created by SMS" in html
    assert f"/admin/sms/smsmessage/{traffic.message.pk}/change/" in html
    assert "#FHEAD 230; #RUDDER 45" in html


def test_a_command_from_the_admin_shows_no_sms(admin_client: Client, command_a: Command) -> None:
    html = admin_client.get(f"/admin/commands/command/{command_a.pk}/change/").content.decode()
    assert "Created by SMS" in html
    assert not re.search(r"/admin/sms/smsmessage/\d+/change/", html)


def test_an_authorised_number_is_normalised_when_saved(
    admin_client: Client, glider: Vessel
) -> None:
    response = admin_client.post(
        "/admin/sms/authorisednumber/add/",
        {"number": "0412 345 678", "name": "Skipper", "vessels": [glider.pk], "role": "control",
         "active": "on", "notes": ""},
    )  # fmt: skip
    assert response.status_code == 302
    entry = AuthorisedNumber.objects.get()
    assert (entry.number, list(entry.vessels.all())) == (SKIPPER, [glider])
    listing = admin_client.get("/admin/sms/authorisednumber/").content.decode()
    assert SKIPPER in listing and "glider" in listing


def test_receives_positions_is_set_in_the_admin_and_off_by_default(
    admin_client: Client, glider: Vessel
) -> None:
    form = {"number": "0412 345 678", "name": "Skipper", "vessels": [glider.pk],
            "role": "query", "active": "on", "notes": ""}  # fmt: skip
    assert (
        "receives_positions"
        in admin_client.get("/admin/sms/authorisednumber/add/").content.decode()
    )
    admin_client.post("/admin/sms/authorisednumber/add/", form)
    entry = AuthorisedNumber.objects.get()
    assert entry.receives_positions is False
    change = f"/admin/sms/authorisednumber/{entry.pk}/change/"
    assert admin_client.post(change, {**form, "receives_positions": "on"}).status_code == 302
    entry.refresh_from_db()
    assert entry.receives_positions is True
    listing = admin_client.get("/admin/sms/authorisednumber/?receives_positions__exact=1")
    assert SKIPPER in listing.content.decode()


def test_an_invalid_number_is_a_clear_form_error(admin_client: Client, glider: Vessel) -> None:
    response = admin_client.post(
        "/admin/sms/authorisednumber/add/",
        {"number": "12345", "name": "Nobody", "vessels": [glider.pk], "role": "query"},
    )
    assert response.status_code == 200
    assert "is not a valid phone number" in response.content.decode()
    assert not AuthorisedNumber.objects.exists()


def test_the_same_number_in_another_form_is_a_duplicate(
    admin_client: Client, glider: Vessel, traffic: Any
) -> None:
    response = admin_client.post(
        "/admin/sms/authorisednumber/add/",
        {"number": "+61 412-345-678", "name": "Twin", "vessels": [glider.pk], "role": "query"},
    )
    assert response.status_code == 200
    assert "already exists" in response.content.decode()
    assert AuthorisedNumber.objects.count() == 1


def test_the_deauthorise_action_makes_numbers_inactive(admin_client: Client, traffic: Any) -> None:
    entry = AuthorisedNumber.objects.get()
    admin_client.post(
        "/admin/sms/authorisednumber/",
        {"action": "deauthorise", "_selected_action": [entry.pk]},
    )
    entry.refresh_from_db()
    assert not entry.active
    assert SmsMessage.objects.filter(authorised_number=entry).exists()  # the log keeps its name


def test_the_sms_log_reads_times_in_utc_with_seconds(admin_client: Client, traffic: Any) -> None:
    # The list's own column and Django's fields on the message page read the same way.
    listed = admin_client.get("/admin/sms/smsmessage/").content.decode()
    message = SmsMessage.objects.get(pk=traffic.message.pk)
    assert f'<span class="nowrap">{fmt_time(message.created_at)}</span>' in listed
    page = admin_client.get(f"/admin/sms/smsmessage/{message.pk}/change/").content.decode()
    assert fmt_time(message.received_at) == BASE.strftime("%Y-%m-%d %H:%M:%S UTC")
    assert fmt_time(message.received_at) in page
