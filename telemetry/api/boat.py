"""Telemetry in from boats: v1 `POST /api/v1/boat/telemetry/` and the legacy SPAB `data.cgi`.

The wire shapes are a contract with boats in the field (docs/api.md), so these are explicit
APIViews that build their JSON by hand; :func:`telemetry.services.fix_ingest` does the work.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from django.conf import settings
from django.http import HttpRequest, HttpResponse, HttpResponseBase
from drf_spectacular.types import OpenApiTypes
from drf_spectacular.utils import (
    OpenApiParameter,
    OpenApiResponse,
    extend_schema,
    extend_schema_field,
    inline_serializer,
)
from rest_framework import serializers, status
from rest_framework.exceptions import AuthenticationFailed, NotAuthenticated, ParseError
from rest_framework.renderers import JSONRenderer
from rest_framework.request import Request
from rest_framework.response import Response

from edge_client.contract import exchange
from edge_client.contract import fix as fix_shape
from telemetry.api import parsers
from telemetry.api.parsers import (
    CompactFixesParser,
    LegacyTelemetryJSONParser,
    TelemetryJSONParser,
)
from telemetry.errors import KeyRefused
from telemetry.services import fix_ingest
from vessels.api.boat import BoatView, LegacyBoatView, batch_answer_schema, telem_ack
from vessels.auth import key_is_recent, key_recheck, raw_key
from vessels.models import Vessel

logger = logging.getLogger(__name__)


def records_from_body(data: Any) -> list[Any]:
    """A list of fixes, or {"fixes": [...]}; anything else is a 400 naming the problem."""
    if isinstance(data, dict) and "fixes" in data:
        data = data["fixes"]
    if not isinstance(data, list):
        raise ParseError('Expected a JSON list of fixes, or an object {"fixes": [...]}.')
    return data


@extend_schema_field({"oneOf": [{"type": "string", "format": "date-time"}, {"type": "number"}]})
class FixTime(serializers.Field):
    """ISO 8601 with a UTC offset, or Unix seconds."""


def _number(name: str) -> serializers.FloatField:
    """A fix's number field with the contract's range (edge_client/contract/fix.py)."""
    lo, hi = fix_shape.RANGES[name]
    return serializers.FloatField(required=name in fix_shape.REQUIRED, min_value=lo, max_value=hi)


class FixIn(serializers.Serializer):
    """The wire shape of one fix, for the schema only: telemetry.parsing validates, so that
    one bad fix is reported by index instead of failing the batch."""

    time = FixTime(help_text="ISO 8601 with a UTC offset, or Unix seconds")
    lat = _number("lat")
    lon = _number("lon")
    heading_deg = _number("heading_deg")
    speed_mps = _number("speed_mps")
    battery_v = _number("battery_v")
    readings = serializers.DictField(
        child=serializers.FloatField(),
        required=False,
        help_text=f"name: number, up to {fix_shape.MAX_READINGS}",
    )


_Batch = inline_serializer("TelemetryBatch", {"fixes": FixIn(many=True)})

_IngestResult = batch_answer_schema(
    "IngestResult",
    {
        exchange.ETAG_KEY: serializers.CharField(
            required=False,
            help_text=f"the command list's ETag now; only when the post sent {exchange.HEADER}",
        ),
        exchange.COMMANDS_KEY: serializers.ListField(
            child=serializers.DictField(),
            required=False,
            help_text="the command poll's `commands`; only when the list's ETag differs from "
            f"the one sent in {exchange.HEADER}",
        ),
    },
)


class TelemetryView(BoatView):
    """The boat's everyday request. Its key comes from the recent lookups and its writes check
    the key themselves (one statement fewer per post, benchmark `python -m bench.server
    --single-only`); any error answered is checked against a fresh lookup first, so a key
    revoked meanwhile gets the same 401 as ever."""

    keys_checked_by_writes = True  # vessels.auth.VesselKeyAuthentication
    parser_classes = [TelemetryJSONParser, CompactFixesParser]
    # (vessel, the ETag the boat holds) -> what the answer adds: the commands app's
    # commands.api.boat.commands_exchange, given by fleet.urls (telemetry may not import
    # commands: tests/fleet/test_layers.py). None: the header is ignored.
    commands_exchange: Callable[[Vessel, str], dict[str, Any]] | None = None

    @extend_schema(
        request={"application/json": _Batch, CompactFixesParser.media_type: OpenApiTypes.BINARY},
        parameters=[
            OpenApiParameter(
                exchange.HEADER,
                str,
                OpenApiParameter.HEADER,
                description='the command poll\'s ETag the boat holds (`""`: none yet): the '
                "answer then carries the command list when it changed (docs/api.md)",
            ),
            OpenApiParameter(
                exchange.PREFER_HEADER,
                str,
                OpenApiParameter.HEADER,
                description=f"`{exchange.PREFER}` with {exchange.HEADER}: a batch taken whole "
                "while the boat's list is current is answered 204, with nothing to read",
            ),
        ],
        responses={
            200: _IngestResult,
            204: OpenApiResponse(
                description=f"with {exchange.HEADER} and `Prefer: {exchange.PREFER}`: every "
                "fix stored or already there, and the command list the boat holds is current"
            ),
        },
        tags=["boat"],
    )
    def post(self, request: Request) -> Response:
        """Store a batch of fixes (`{"fixes": [...]}`, or the bare list; or a compact payload,
        `application/vnd.shoreside.fixes`, answered alike). Bad fixes are reported by index;
        the good ones are kept; re-sent fixes count as duplicates."""
        if not request.data and request.content_type.startswith(CompactFixesParser.media_type):
            raise ParseError("compact fixes: the body is empty")  # DRF parses no empty body
        vessel = self.vessel(request)
        result = fix_ingest(
            vessel=vessel, records=records_from_body(request.data), key_id=request.auth.pk
        )
        request._request.link_fixes_in = result.accepted  # links.http counts them
        answer = self.answer(request, vessel, result)
        return settled_response() if answer is None else Response(answer)

    def answer(self, request: HttpRequest | Request, vessel: Vessel, result: Any) -> dict | None:
        """The batch answer, and the command list's exchange when the boat sent the ETag it
        holds (edge_client.contract.exchange; without the header: the answer as ever). None
        for an exchange with nothing to say: answered 204 (``exchange.SETTLED``)."""
        answer = result.as_dict()
        held = request.META.get(exchange.META_KEY)
        if held is not None and self.commands_exchange is not None:
            answer.update(self.commands_exchange(vessel, held))
            prefer = request.META.get(exchange.PREFER_META_KEY)
            if exchange.settled(answer) and exchange.wants_minimal(prefer):
                return None
        return answer

    def dispatch(self, request: HttpRequest, *args: Any, **kwargs: Any) -> HttpResponseBase:
        """The everyday post (:func:`everyday_records`) goes the short way: DRF's own steps,
        less the ones whose outcome is known from that check (content negotiation, the
        parser's choice) or that cost more than the work (its Response's rendering
        machinery: the same bytes from the same renderer); anything else goes DRF's whole
        way. Both answer errors with :meth:`handle_exception`. Benchmark: `python -m
        bench.server --single-only` (issue 17 item 8)."""
        records = everyday_records(request)
        if records is None:
            return super().dispatch(request, *args, **kwargs)
        self.args, self.kwargs = args, kwargs
        drf_request = self.initialize_request(request, *args, **kwargs)
        self.request = drf_request
        self.headers = self.default_response_headers
        try:
            # APIView.initial's checks, in its order (authentication: from the recent keys)
            self.perform_authentication(drf_request)
            self.check_permissions(drf_request)
            self.check_throttles(drf_request)
            vessel = self.vessel(drf_request)
            result = fix_ingest(vessel=vessel, records=records, key_id=drf_request.auth.pk)
            request.link_fixes_in = result.accepted  # type: ignore[attr-defined]
            answer = self.answer(request, vessel, result)
            response: HttpResponseBase = (
                settled_response()
                if answer is None
                else HttpResponse(
                    JSONRenderer().render(answer), content_type=JSONRenderer.media_type
                )
            )
        except Exception as exc:
            response = self.handle_exception(exc)
        self.response = self.finalize_response(drf_request, response, *args, **kwargs)
        return self.response

    def handle_exception(self, exc: Exception) -> Response:
        if not isinstance(exc, AuthenticationFailed | NotAuthenticated):
            try:
                key_recheck(self.request)
            except AuthenticationFailed as refused:
                exc = refused
            else:
                if isinstance(exc, KeyRefused):  # it works again (un-revoked meanwhile): rare
                    exc = AuthenticationFailed("Invalid vessel key.")
        return super().handle_exception(exc)


def settled_response() -> HttpResponse:
    """204 No Content, with no Content-Type either (Django adds one to every response)."""
    response = HttpResponse(status=exchange.SETTLED)
    del response["Content-Type"]
    return response


def everyday_records(request: HttpRequest) -> list[Any] | None:
    """The fixes of a boat's everyday post, or None if it is anything else.

    Everyday: a POST of a JSON body (`Content-Type: application/json`, no parameters) whose
    fixes are a list of at most FIX_MAX_BATCH, with a key this process looked up lately (no
    query to ask for it). This only looks: nothing is counted, touched or written, so
    whatever it says None to, DRF takes from the start and answers as ever (401, 415, 400,
    413…). The body is read as TelemetryJSONParser reads it; DRF would read it again from
    the copy Django keeps."""
    if request.method != "POST" or request.META.get("CONTENT_TYPE") != "application/json":
        return None
    if not key_is_recent(raw_key(request)):
        return None
    try:
        length = int(request.META.get("CONTENT_LENGTH") or 0)
    except ValueError:
        return None
    limit = settings.DATA_UPLOAD_MAX_MEMORY_SIZE
    if length <= 0 or (limit is not None and length > limit):
        return None
    try:
        data = parsers.loads(request.body.decode(request.encoding or settings.DEFAULT_CHARSET))
    except (ValueError, RecursionError):  # ValueError includes UnicodeDecodeError
        return None
    if isinstance(data, dict) and "fixes" in data:
        data = data["fixes"]
    if not isinstance(data, list) or len(data) > settings.FIX_MAX_BATCH:
        return None
    return data


@extend_schema(exclude=True)
class LegacyDataView(LegacyBoatView):
    """`POST /spab/data.cgi`: legacy SPAB records (one object or a list) → `telemAck`."""

    parser_classes = [LegacyTelemetryJSONParser]

    def post(self, request: Request) -> Response:
        data = request.data
        records = [data] if isinstance(data, dict) else data
        if not isinstance(records, list):
            return Response(
                telem_ack(False, "expected a JSON object or a list of objects"),
                status=status.HTTP_400_BAD_REQUEST,
            )
        result = fix_ingest(vessel=self.vessel(request), records=records, legacy=True)
        request._request.link_fixes_in = result.accepted  # links.http counts them
        message = (
            f"accepted {result.accepted}, duplicates {result.duplicates}, "
            f"rejected {len(result.rejected)}"
        )
        for rejected in result.rejected:
            fields = ", ".join(f"{k} {v}" for k, v in rejected["errors"].items())
            message += f"; record {rejected['index']}: {fields}"
        if result.rejected:
            # The old client may not read its telemAck: the log is where a rejection shows.
            # repr and cut: the names are the vessel's own text, a batch may reject hundreds.
            logger.warning("data.cgi from %s: %.2000r", self.vessel(request).slug, message)
        ok = not result.rejected
        return Response(
            telem_ack(ok, message),
            status=200 if ok or result.accepted or result.duplicates else 400,
        )
