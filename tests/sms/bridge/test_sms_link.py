"""The modem thread's units called one at a time against the modem simulator on a real pty:
receive → store → delete, replies sent once whatever the modem answers (issue 10 item 4 through
the real service; issue 11 §1)."""

from __future__ import annotations

import logging
from collections.abc import Iterator

import pytest

from sms.bridge.sms_link import SmsLink
from sms.models import Direction, SendStatus, SmsMessage
from sms.modem import Modem, ModemConfig
from sms.modem.simulator import ModemServer, SimulatedModem
from vessels.models import Vessel

from .rig import FAST_MODEM, QUERY, authorise, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]


@pytest.fixture
def sim() -> Iterator[tuple[SimulatedModem, ModemServer]]:
    modem = SimulatedModem()
    with ModemServer(modem, "pty") as server:
        yield modem, server


def link_for(glider: Vessel, url: str, **modem: object) -> SmsLink:
    config = ModemConfig(url, **{**FAST_MODEM, **modem})  # type: ignore[arg-type]
    return SmsLink(vessel=glider, modem=Modem(config), retry_base_s=0.05)


def test_a_message_is_stored_answered_and_deleted_and_a_new_link_finds_nothing_twice(
    glider: Vessel, sim: tuple[SimulatedModem, ModemServer]
) -> None:
    authorise(glider)
    modem, server = sim
    modem.inject(QUERY, "#FHEAD")
    first = link_for(glider, server.url)
    assert wait_for(lambda: first.do_one_receive(0.2))
    assert modem.store == {}
    assert first.do_one_send() and not first.do_one_send()
    first.modem.close()
    second = link_for(glider, server.url)  # a restart: a new driver re-lists the SIM
    second.do_one_receive(0.5)
    assert not second.do_one_send()
    second.modem.close()
    assert [(s.number, s.text) for s in modem.sent] == [(QUERY, "#FHEAD unknown")]


def test_a_reply_with_no_answer_from_the_modem_is_marked_sent_unconfirmed_not_resent(
    glider: Vessel, sim: tuple[SimulatedModem, ModemServer]
) -> None:
    authorise(glider)
    modem, server = sim
    modem.inject(QUERY, "#FHEAD")
    link = link_for(glider, server.url, send_timeout_s=0.3)
    assert wait_for(lambda: link.do_one_receive(0.2))
    modem.faults.send_delay_s = 1.0  # the text went out; +CMGS comes after the driver gave up
    assert link.do_one_send()
    reply = SmsMessage.objects.get(direction=Direction.OUT)
    assert reply.status == SendStatus.SENT and reply.status_detail.startswith("unconfirmed")
    modem.faults.send_delay_s = 0.0
    link.do_one_receive(1.5)  # the late answer drains away
    assert not link.do_one_send()
    link.modem.close()
    assert len(modem.sent) == 1


def test_a_strangers_text_stays_out_of_the_info_log_but_in_the_sms_log(
    glider: Vessel, sim: tuple[SimulatedModem, ModemServer], caplog: pytest.LogCaptureFixture
) -> None:
    authorise(glider)
    modem, server = sim
    modem.inject("+61499999999", "my private words")
    modem.inject(QUERY, "#FHEAD")
    link = link_for(glider, server.url)
    with caplog.at_level(logging.INFO, logger="sms.bridge.sms_link"):
        both_in = SmsMessage.objects.filter(direction=Direction.IN)
        assert wait_for(lambda: link.do_one_receive(0.2) is not None and both_in.count() == 2)
    link.modem.close()
    info = [r.getMessage() for r in caplog.records if r.levelno >= logging.INFO]
    assert any("+61499999999" in m and "stranger" in m for m in info)
    assert not any("my private words" in m for m in info)
    assert any("#FHEAD" in m for m in info)  # an authorised number's text is still logged
    stored = SmsMessage.objects.get(number="+61499999999")
    assert (stored.text, stored.outcome) == ("my private words", "stranger")


def test_a_rate_limited_number_gets_one_notice_through_the_modem_then_silence(
    glider: Vessel, sim: tuple[SimulatedModem, ModemServer], settings: object
) -> None:
    settings.SMS_RATE_LIMIT, settings.SMS_RATE_WINDOW_S = 1, 600  # type: ignore[attr-defined]
    authorise(glider)
    modem, server = sim
    for text in ("#FHEAD", "#LIGHT", "#IR"):
        modem.inject(QUERY, text)
    link = link_for(glider, server.url)
    received = SmsMessage.objects.filter(direction=Direction.IN)
    assert wait_for(lambda: link.do_one_receive(0.2) is not None and received.count() == 3)
    while link.do_one_send():
        pass
    link.modem.close()
    texts = [s.text for s in modem.sent]
    assert [s.number for s in modem.sent] == [QUERY, QUERY]
    assert texts[0] == "#FHEAD unknown"
    assert texts[1].startswith("SMS limit reached (1 per 10 min): texts are not answered until ")
    outcomes = [m.outcome for m in received.order_by("pk")]
    assert outcomes == ["accepted", "rate_limited", "rate_limited"]
