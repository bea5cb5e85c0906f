"""OpenAPI: every operation documents the errors it can answer, in the one error shape.

A drf-spectacular postprocessing hook rather than an `extend_schema` on each view: which
errors an operation can give follows from what it takes (auth, a body, path parameters), and
one rule here keeps the schema true as endpoints are added (issue: schemathesis found
400/401/403/404/409/415 undocumented).
"""

from __future__ import annotations

from typing import Any

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
    "401": "No credentials, or a bad / revoked key or token",
    "403": "Authenticated, but without the permission this needs",
    "404": "No such object for this caller",
    "409": "The command's status does not allow this any more",
    "413": "The body is over DATA_UPLOAD_MAX_MEMORY_SIZE",
    "415": "The body is not application/json",
    "429": "Over this vessel's or operator's request rate; retry after Retry-After seconds",
    "503": "The database is away for a moment; retry after Retry-After seconds",
}
# Operations whose object can be in a state that refuses the request.
CONFLICTS = ("/ack/", "/cancel/")


def error_codes(path: str, method: str, operation: dict[str, Any]) -> list[str]:
    """The error statuses an operation can answer, from what it takes."""
    codes = ["401", "403", "429", "503"]
    if "requestBody" in operation:
        codes += ["400", "413", "415"]
    if any(p.get("in") == "query" for p in operation.get("parameters", [])):
        codes.append("400")
    if "{" in path:
        codes.append("404")
    if method == "post" and path.endswith(CONFLICTS):
        codes.append("409")
    return sorted(set(codes))


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
    return result
