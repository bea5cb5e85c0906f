"""The outgoing queue the modem loop sends: pending replies, marked sent or failed once."""

from __future__ import annotations

import datetime as dt

from sms.models import Direction, SendStatus, SmsMessage
from sms.services._common import DETAIL_MAX
from vessels.models import Vessel


def sms_outgoing_pending(*, vessel: Vessel) -> list[SmsMessage]:
    """The vessel's replies waiting for the modem, oldest first."""
    return list(
        SmsMessage.objects.filter(
            vessel=vessel, direction=Direction.OUT, status=SendStatus.PENDING
        ).order_by("created_at", "pk")
    )


def _settle(message: SmsMessage, changes: dict[str, object]) -> bool:
    """Move a pending outgoing SMS on, once: a conditional UPDATE, so a second mark is a no-op."""
    won = (
        SmsMessage.objects.filter(
            pk=message.pk, direction=Direction.OUT, status=SendStatus.PENDING
        ).update(**changes)
        == 1
    )
    if won:
        for name, value in changes.items():
            setattr(message, name, value)
    return won


def sms_mark_sent(
    *, message: SmsMessage, reference: int | str, now: dt.datetime, detail: str = ""
) -> bool:
    """The modem took the SMS (``+CMGS: <reference>``); False if it was not pending.

    ``detail`` says when it is not sure (the text went out and no answer came): such an SMS is
    counted as sent, never sent again, so that nobody gets the same reply twice."""
    return _settle(
        message,
        {
            "status": SendStatus.SENT,
            "reference": str(reference)[:20],
            "sent_at": now,
            "status_detail": detail[:DETAIL_MAX],
        },
    )


def sms_mark_failed(*, message: SmsMessage, reason: str, now: dt.datetime) -> bool:
    """The modem refused the SMS for good (``+CMS ERROR``); False if it was not pending."""
    return _settle(
        message,
        {"status": SendStatus.FAILED, "status_detail": reason[:DETAIL_MAX], "sent_at": None},
    )
