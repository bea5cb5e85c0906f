"""The modem thread's units called one at a time against the modem simulator on a real pty:
receive → store → delete, replies sent once whatever the modem answers (issue 10 item 4 through
the real service; issue 11 §1)."""

from __future__ import annotations

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
