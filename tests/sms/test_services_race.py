"""Two deliveries of one SMS racing (a modem re-read while the first is still being stored):
real transactions on a real database, in two threads."""

from __future__ import annotations

import datetime as dt
import threading
import time

import pytest
from django.db import connection, transaction

from commands.models import Command
from sms.models import SmsMessage
from sms.services import authorised_number_authorise, sms_handle_incoming
from tests.support import BASE
from vessels.models import Vessel

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]
HEAD_START_S = 0.3  # lets the second delivery read before the first commits (not asserted)


def test_a_delivery_racing_its_twin_is_handled_once(glider: Vessel) -> None:
    authorised_number_authorise(number="+61412345678", vessels=[glider], role="control", name="S")
    stored, release = threading.Event(), threading.Event()
    results: dict[str, object] = {}

    def handle() -> object:
        return sms_handle_incoming(
            vessel=glider, number="+61412345678", text="#FHEAD 230",
            received_at=BASE, modem_timestamp=BASE,
        )  # fmt: skip

    def deliver(name: str, hold_open: bool) -> None:
        try:
            if hold_open:
                with transaction.atomic():
                    results[name] = handle()
                    stored.set()  # stored, not committed yet
                    release.wait(10)
            else:
                results[name] = handle()
        finally:
            connection.close()

    first = threading.Thread(target=deliver, args=("first", True))
    first.start()
    assert stored.wait(10)
    second = threading.Thread(target=deliver, args=("second", False))
    second.start()
    time.sleep(HEAD_START_S)
    release.set()
    first.join(20)
    second.join(20)

    assert not results["first"].duplicate
    assert results["second"].duplicate
    assert results["second"].message.pk == results["first"].message.pk
    assert results["second"].reply_texts == ["#FHEAD 230 QUEUED"]
    assert Command.objects.count() == 1
    assert SmsMessage.objects.count() == 2


def test_two_texts_over_the_limit_at_once_give_one_notice(glider: Vessel, settings: object) -> None:
    settings.SMS_RATE_LIMIT, settings.SMS_RATE_WINDOW_S = 1, 600  # type: ignore[attr-defined]
    authorised_number_authorise(number="+61412345678", vessels=[glider], role="control", name="S")
    sms_handle_incoming(
        vessel=glider, number="+61412345678", text="#STATUS", received_at=BASE
    )  # the one answered: the block runs to 08:10
    stored, release = threading.Event(), threading.Event()
    results: dict[str, object] = {}

    def handle(seconds: int) -> object:
        when = BASE + dt.timedelta(seconds=seconds)
        return sms_handle_incoming(
            vessel=glider, number="+61412345678", text=f"#LIGHT {seconds}",
            received_at=when, modem_timestamp=when,
        )  # fmt: skip

    def deliver(name: str, seconds: int, hold_open: bool) -> None:
        try:
            if hold_open:
                with transaction.atomic():
                    results[name] = handle(seconds)
                    stored.set()  # its notice written, not committed yet
                    release.wait(10)
            else:
                results[name] = handle(seconds)
        finally:
            connection.close()

    first = threading.Thread(target=deliver, args=("first", 10, True))
    first.start()
    assert stored.wait(10)
    second = threading.Thread(target=deliver, args=("second", 11, False))
    second.start()
    time.sleep(HEAD_START_S)
    release.set()
    first.join(20)
    second.join(20)

    assert [results[n].outcome for n in ("first", "second")] == ["rate_limited"] * 2
    assert len(results["first"].replies) == 1
    assert results["second"].replies == ()
    notices = SmsMessage.objects.filter(direction="out", text__startswith="SMS limit")
    assert notices.count() == 1
