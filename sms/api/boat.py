"""The glider's shore link on the shore side (issue 11 §6, docs/wave-glider.md).

- ``GET /api/v1/boat/numbers/``: the numbers that may address the caller's vessel, with an
  ETag (``If-None-Match`` → 304: the glider syncs over 3G or satellite). The shore admin is
  where numbers are managed; the glider keeps the last list it got.
- ``POST /api/v1/boat/sms/``: a batch of the glider's SMS log, stored in the shore's log. Each
  entry carries the glider's own id: a re-sent entry is a duplicate, one bad entry never loses
  the good ones (the answer has the shape of the telemetry upload's).

Explicit APIViews with hand-built JSON, like the other boat endpoints: the wire shapes are a
contract with vessels in the field. :mod:`sms.services` checks the entries' rules and does the
writing (``sms_log_upload``).
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

from django.http import HttpResponseNotModified
from drf_spectacular.utils import OpenApiParameter, extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.exceptions import ParseError
from rest_framework.request import Request
from rest_framework.response import Response

from sms.models import (
    E164_MAX,
    ORIGIN_ID_MAX,
    RAW_NUMBER_MAX,
    AuthorisedNumber,
    Direction,
    Outcome,
    Role,
    SendStatus,
)
from sms.services import DETAIL_MAX, TEXT_STORE_MAX, sms_log_upload
from vessels.api.boat import AwareDateTimeField, BoatView, batch_answer_schema
from vessels.api.conditional import etag_matches
from vessels.batch import Unreadable
from vessels.models import Vessel
from vessels.text import json_size, json_unstorable

# Entries per upload: the glider sends its backlog in batches of this size or fewer.
SMS_UPLOAD_MAX_BATCH = 500
COMMANDS_PER_SMS_MAX = 50
# An entry's `parsed`, as compact UTF-8 JSON. Unbounded, one entry stored 1 MB that the SMS
# log's pages then read. The largest the glider makes is about 20 KB: the language reads at
# most MAX_TEXT (1,600) characters and echoes each part twice at worst (its text and an
# "unknown command ..." error), a control character taking 6 bytes as JSON.
PARSED_MAX_BYTES = 32 * 1024


def numbers_wire(vessel: Vessel) -> list[dict[str, Any]]:
    """The numbers that may address ``vessel`` (active or not: the glider mirrors both)."""
    entries = AuthorisedNumber.objects.filter(vessels=vessel).order_by("number")
    return [
        {
            "number": entry.number,
            "name": entry.name,
            "role": entry.role,
            "active": entry.active,
            "expires_at": entry.expires_at.isoformat() if entry.expires_at else None,
            "receives_positions": entry.receives_positions,
        }
        for entry in entries
    ]


def numbers_etag(numbers: list[dict[str, Any]]) -> str:
    """A strong tag over the list's content: it changes exactly when the list does."""
    raw = json.dumps(numbers, sort_keys=True, separators=(",", ":")).encode()
    return f'"n{hashlib.sha256(raw).hexdigest()[:24]}"'


_NumberOut = inline_serializer(
    "BoatAuthorisedNumber",
    many=True,
    fields={
        "number": serializers.CharField(max_length=E164_MAX, help_text="E.164"),
        "name": serializers.CharField(),
        "role": serializers.ChoiceField(Role.choices),
        "active": serializers.BooleanField(),
        "expires_at": serializers.DateTimeField(allow_null=True),
        "receives_positions": serializers.BooleanField(
            help_text="the glider's bridge texts it the glider's position on its schedule"
        ),
    },
)


class NumbersView(BoatView):
    @extend_schema(
        parameters=[OpenApiParameter("If-None-Match", str, OpenApiParameter.HEADER)],
        responses={200: inline_serializer("BoatNumbers", {"numbers": _NumberOut}), 304: None},
        tags=["boat"],
    )
    def get(self, request: Request) -> Response | HttpResponseNotModified:
        """The authorised numbers that may address this vessel; `304` when the ETag matches."""
        numbers = numbers_wire(self.vessel(request))
        etag = numbers_etag(numbers)
        if etag_matches(request.META.get("HTTP_IF_NONE_MATCH"), etag):
            response = HttpResponseNotModified()
        else:
            response = Response({"numbers": numbers})
        response["ETag"] = etag
        return response


class SmsEntryIn(serializers.Serializer):
    """One entry of the vessel's SMS log as the glider uploads it."""

    id = serializers.CharField(max_length=ORIGIN_ID_MAX, help_text="the vessel's own, stable id")
    direction = serializers.ChoiceField(Direction.choices)
    number = serializers.CharField(max_length=RAW_NUMBER_MAX, trim_whitespace=False)
    text = serializers.CharField(
        max_length=TEXT_STORE_MAX, allow_blank=True, trim_whitespace=False, required=False
    )
    created_at = AwareDateTimeField(help_text="when the vessel logged it")
    received_at = AwareDateTimeField(required=False, allow_null=True)
    modem_timestamp = AwareDateTimeField(required=False, allow_null=True)
    sent_at = AwareDateTimeField(required=False, allow_null=True)
    authorised = serializers.BooleanField(required=False, default=False)
    outcome = serializers.ChoiceField(
        Outcome.choices, required=False, allow_blank=True, help_text="incoming only"
    )
    detail = serializers.CharField(max_length=DETAIL_MAX, required=False, allow_blank=True)
    status = serializers.ChoiceField(
        SendStatus.choices, required=False, allow_blank=True, help_text="outgoing only"
    )
    status_detail = serializers.CharField(max_length=DETAIL_MAX, required=False, allow_blank=True)
    reference = serializers.CharField(max_length=20, required=False, allow_blank=True)
    parsed = serializers.ListField(
        child=serializers.DictField(),
        required=False,
        help_text=f"each part as understood; at most {PARSED_MAX_BYTES} bytes as JSON",
    )
    reply_to = serializers.CharField(
        max_length=ORIGIN_ID_MAX, required=False, allow_null=True, help_text="the id it answers"
    )
    commands = serializers.ListField(
        child=serializers.UUIDField(),
        required=False,
        max_length=COMMANDS_PER_SMS_MAX,
        help_text="uids of the commands it created",
    )

    def validate_parsed(self, value: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """Free-form JSON: every string in it, keys too, must be storable (PostgreSQL's jsonb
        refused a NUL with a 500 that lost the rest of the batch), and its size is bounded."""
        if problem := json_unstorable(value):
            raise serializers.ValidationError(problem)
        if (size := json_size(value)) > PARSED_MAX_BYTES:
            raise serializers.ValidationError(
                f"is {size} bytes as JSON; at most {PARSED_MAX_BYTES}"
            )
        return value


def entries_from_body(data: Any) -> list[Any]:
    """A list of entries, or {"messages": [...]}; anything else is a 400 naming the problem."""
    if isinstance(data, dict) and "messages" in data:
        data = data["messages"]
    if not isinstance(data, list):
        raise ParseError('Expected a JSON list of SMS log entries, or {"messages": [...]}.')
    if len(data) > SMS_UPLOAD_MAX_BATCH:
        raise ParseError(f"At most {SMS_UPLOAD_MAX_BATCH} entries per upload.")
    return data


_UploadResult = batch_answer_schema("SmsUploadResult")


class SmsLogView(BoatView):
    @extend_schema(
        request=inline_serializer("SmsUpload", {"messages": SmsEntryIn(many=True)}),
        responses={200: _UploadResult},
        tags=["boat"],
    )
    def post(self, request: Request) -> Response:
        """Store a batch of the vessel's SMS log (`{"messages": [...]}` or the bare list). Bad
        entries are reported by index, the good ones kept; re-sent ids count as duplicates."""
        entries = [_entry_read(raw) for raw in entries_from_body(request.data)]
        answer = sms_log_upload(vessel=self.vessel(request), entries=entries)
        return Response(answer.as_dict())


def _entry_read(raw: Any) -> dict[str, Any] | Unreadable:
    """One entry's wire shape, read; its times and direction are the service's to check."""
    entry = SmsEntryIn(data=raw) if isinstance(raw, dict) else None
    if entry is None or not entry.is_valid():
        return Unreadable(entry.errors if entry is not None else {"entry": ["not an object"]})
    return dict(entry.validated_data)
