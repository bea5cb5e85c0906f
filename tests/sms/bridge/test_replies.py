"""An SMS command's reply through the bridge's answer path: the SMS queues the command, the C&C
takes it and answers (§8.5, §8.6 of docs/level2.md), and the held reply says what happened (issue 11
§3), from the answer the bridge recorded on the command's events, not from the prose beside it
(issue 17 item 4)."""

from __future__ import annotations

import pytest

from commands.models import Command
from sms.bridge.commands import DatabaseCommandSource
from sms.bridge.machine import BridgeMachine
from sms.level2.inner import InnerCommandTable
from sms.models import Direction, SmsMessage
from sms.services import authorised_number_authorise, sms_handle_incoming, sms_replies_due
from vessels.models import Vessel

from .conftest import Clock, queued, result

pytestmark = pytest.mark.django_db

PHONE = "+61400000001"


def answer(glider: Vessel, clock: Clock, text: str, code: int) -> list[str]:
    """Text ``text`` in, let the C&C take the command and answer ``code``: the replies sent."""
    authorised_number_authorise(number=PHONE, vessels=[glider], role="control", name="Skipper")
    sms_handle_incoming(
        vessel=glider, number=PHONE, text=text, received_at=clock(), reply_window_s=30
    )
    source = DatabaseCommandSource(vessel=glider, clock=clock)
    machine = BridgeMachine(source=source)
    machine.handle(queued(0x1A))
    machine.handle(result(code, 0x1B))
    assert Command.objects.get().status in ("done", "failed")
    sms_replies_due(vessel=glider, now=clock())
    return list(
        SmsMessage.objects.filter(direction=Direction.OUT)
        .order_by("pk")
        .values_list("text", flat=True)
    )


@pytest.mark.parametrize(
    ("code", "reply"), [(0, "#FHEAD 230 OK"), (2, "#FHEAD 230 FAILED invalid data")]
)
def test_the_reply_says_the_cc_answer(glider: Vessel, clock: Clock, code: int, reply: str) -> None:
    assert answer(glider, clock, "#FHEAD 230", code) == [reply]


def test_the_reply_reads_the_recorded_answer_whatever_the_detail_says(
    glider: Vessel, clock: Clock, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Operators may get other words; the reply must not depend on them.
    monkeypatch.setattr("sms.bridge.commands.NAK_DETAIL", "the C&C box said no ({meaning}, {code})")
    assert answer(glider, clock, "#FHEAD 230", 2) == ["#FHEAD 230 FAILED invalid data"]
    assert Command.objects.get().result_detail == "the C&C box said no (invalid data, 2)"


def test_a_command_the_table_refuses_is_replied_with_the_tables_reason(
    glider: Vessel, clock: Clock, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("sms.bridge.commands.REFUSED_DETAIL", "not sent ({reason})")
    authorised_number_authorise(number=PHONE, vessels=[glider], role="control", name="Skipper")
    sms_handle_incoming(
        vessel=glider, number=PHONE, text="#FHEAD 230", received_at=clock(), reply_window_s=30
    )
    # The table changed between the SMS and the handover: fhead is gone from it.
    shipped = InnerCommandTable.load()
    table = InnerCommandTable(
        shipped.settings, {w: spec for w, spec in shipped.commands.items() if w != "fhead"}
    )
    machine = BridgeMachine(source=DatabaseCommandSource(vessel=glider, table=table, clock=clock))
    machine.handle(queued(0x1A))
    assert Command.objects.get().result_detail.startswith("not sent (not in the inner")
    sms_replies_due(vessel=glider, now=clock())
    (reply,) = SmsMessage.objects.filter(direction=Direction.OUT).values_list("text", flat=True)
    assert reply.startswith("#FHEAD 230 FAILED not in the inner command table"), reply
