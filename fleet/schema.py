"""OpenAPI: every operation documents the errors it can answer, in the one error shape.

A drf-spectacular postprocessing hook rather than an `extend_schema` on each view: which
errors an operation can give follows from what it takes (auth, a body, path parameters), and
one rule here keeps the schema true as endpoints are added (issue: schemathesis found
400/401/403/404/409/415 undocumented).
"""

from __future__ import annotations

from typing import Any

from django.conf import settings
from drf_spectacular.views import SpectacularAPIView
from rest_framework.renderers import JSONRenderer
from rest_framework.response import Response

ERROR_SCHEMA = {
    "type": "object",
    "properties": {
        "error": {"type": "string", "description": "a stable code, e.g. not_found"},
        "detail": {
            "description": "a message, or field name → messages",
            "oneOf": [
                {"type": "string"},
                {"type": "object", "additionalProperties": True},
                {"type": "array", "items": {}},
            ],
        },
    },
    "required": ["error", "detail"],
}
DESCRIPTIONS = {
    "400": "Malformed or invalid input (the detail names the field)",
    "401": "No vessel key, or a bad or revoked one (`WWW-Authenticate: Api-Key`)",
    # The session scheme comes first, and it names no WWW-Authenticate challenge, so DRF
    # answers 403 for missing or bad operator credentials too (RFC 9110 §15.5.2 needs one).
    "403": "Not logged in, a bad or expired token, or without the permission this needs",
    "404": "No such object for this caller (a NUL in the path or the query names none)",
    "409": "The command's status does not allow this any more",
    "413": "The body is over DATA_UPLOAD_MAX_MEMORY_SIZE",
    "415": "The body is not application/json",
    "429": "Over this vessel's or operator's request rate; retry after Retry-After seconds",
    "503": "The database is away for a moment; retry after Retry-After seconds",
}
# Operations whose object can be in a state that refuses the request.
CONFLICTS = ("/ack/", "/cancel/")


def auth_codes(operation: dict[str, Any]) -> list[str]:
    """What an operation answers when the caller may not call it.

    Boat operations (vessel key only) answer 401 for no key or a bad one, and nothing else
    gets past their authentication; operator operations answer 403 for everything (see 403).
    """
    schemes = {name for requirement in operation.get("security", []) for name in requirement}
    return ["401"] if schemes == {"vesselKey"} else ["403"]


def error_codes(path: str, method: str, operation: dict[str, Any]) -> list[str]:
    """The error statuses an operation can answer, from what it takes."""
    codes = [*auth_codes(operation), "429", "503"]
    if "requestBody" in operation:
        codes += ["400", "413", "415"]
    query = [p for p in operation.get("parameters", []) if p.get("in") == "query"]
    if query:
        codes.append("400")
    # A NUL in a text parameter is a 404 before any view (fleet.middleware.RejectNulMiddleware).
    if "{" in path or any(p.get("schema", {}).get("type") == "string" for p in query):
        codes.append("404")
    if method == "post" and path.endswith(CONFLICTS):
        codes.append("409")
    return sorted(set(codes))


def _batch_limits() -> dict[str, tuple[str, int, bool]]:
    """Per batch upload: its list's field, the batch limit, whether a bare list is taken."""
    # Imported here: the apps' API modules need the apps loaded, this module is read earlier.
    from commands.api.boat import COMMAND_REPORT_MAX_BATCH
    from sms.api.boat import SMS_UPLOAD_MAX_BATCH

    return {
        "/api/v1/boat/telemetry/": ("fixes", settings.FIX_MAX_BATCH, True),
        "/api/v1/boat/sms/": ("messages", SMS_UPLOAD_MAX_BATCH, True),
        "/api/v1/boat/commands/report/": ("commands", COMMAND_REPORT_MAX_BATCH, False),
    }


# The boats' batch uploads check each entry alone: a bad entry is listed by index in the
# 200's `rejected` and the good ones are stored. So an entry's schema says what is stored,
# while the batch takes any entry (up to the batch limit, over which it is a 400).
OTHER_ENTRY = {"description": "anything else: refused alone, by index, in `rejected`"}


def describe_batches(result: dict[str, Any], limits: dict[str, tuple[str, int, bool]]) -> None:
    schemas = result.get("components", {}).get("schemas", {})
    for path, (field, limit, bare_list) in limits.items():
        request = result["paths"][path]["post"]["requestBody"]
        request["required"] = True  # drf-spectacular leaves it out beside a binary body
        body = request["content"]["application/json"]
        batch = schemas[body["schema"]["$ref"].rsplit("/", 1)[1]]
        entries = batch["properties"][field]
        entries["items"] = {"anyOf": [entries["items"], OTHER_ENTRY]}
        entries["maxItems"] = limit
        if bare_list:
            body["schema"] = {"anyOf": [body["schema"], {**entries, "description": "the list"}]}


def add_error_responses(result: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
    schemas = result.setdefault("components", {}).setdefault("schemas", {})
    schemas["Error"] = ERROR_SCHEMA
    ref = {"$ref": "#/components/schemas/Error"}
    for path, operations in result.get("paths", {}).items():
        for method, operation in operations.items():
            responses = operation.setdefault("responses", {})
            for code in error_codes(path, method, operation):
                responses.setdefault(
                    code,
                    {
                        "description": DESCRIPTIONS[code],
                        "content": {"application/json": {"schema": ref}},
                    },
                )
    describe_batches(result, _batch_limits())
    return result


class SchemaView(SpectacularAPIView):
    """The schema, as YAML or JSON; its own errors (a 403 without a login) in the API's one
    JSON error shape rather than rendered as YAML."""

    def handle_exception(self, exc: Exception) -> Response:
        response = super().handle_exception(exc)
        self.request.accepted_renderer = JSONRenderer()
        self.request.accepted_media_type = JSONRenderer.media_type
        return response
