"""What the glider's shore link (``sms.bridge.shore``) sends up, as the boat API takes it:
a local command for ``POST boat/commands/report/``, a local SMS log entry for ``POST boat/sms/``;
and the shore's times as read off a polled command."""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.utils.dateparse import parse_datetime

from commands.models import Command
from sms.models import SmsMessage

REPORT_DETAIL_MAX = 2000  # the longest result_detail the shore takes in a report


def when(value: Any) -> dt.datetime | None:
    if not isinstance(value, str) or not value:
        return None
    return parse_datetime(value)


def iso(value: dt.datetime | None) -> str | None:
    return value.isoformat() if value is not None else None


def command_report_wire(command: Command) -> dict[str, Any]:
    """A local command as ``POST boat/commands/report/`` takes it: as it stands now.

    The C&C's answer travels as ``result_detail``, for the shore's operators. Its fields on the
    events here (``cc_code``, ``cc_reason``, the request's ``tid``) stay on the glider: nothing
    on the shore reads them (it sends no SMS replies, and a tid means nothing off this serial
    link), and an optional field can still be added later without breaking either side."""
    return {
        "uid": str(command.uid),
        "kind": command.kind,
        "params": command.params,
        "source": command.source,
        "created_by": command.created_by,
        "created_at": command.created_at.isoformat(),
        "status": command.status,
        "sent_at": iso(command.sent_at),
        "acknowledged_at": iso(command.acknowledged_at),
        "finished_at": iso(command.finished_at),
        "result_detail": command.result_detail[:REPORT_DETAIL_MAX],
    }


def sms_wire(message: SmsMessage) -> dict[str, Any]:
    """A local SMS log entry as ``POST boat/sms/`` takes it; ``id`` is the local pk."""
    return {
        "id": str(message.pk),
        "direction": message.direction,
        "number": message.number,
        "text": message.text,
        "created_at": message.created_at.isoformat(),
        "received_at": iso(message.received_at),
        "modem_timestamp": iso(message.modem_timestamp),
        "sent_at": iso(message.sent_at),
        "authorised": message.authorised,
        "outcome": message.outcome,
        "detail": message.detail,
        "status": message.status,
        "status_detail": message.status_detail,
        "reference": message.reference,
        "parsed": message.parsed or [],
        "reply_to": str(message.reply_to_id) if message.reply_to_id else None,
        "commands": [str(c.uid) for c in message.commands.all()],
    }
