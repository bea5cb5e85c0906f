"""One exchange per period (docs/api.md#one-exchange-per-period): the telemetry post's answer
carries the vessel's command list when it changed since the version the boat holds.

The boat sends the command poll's ETag it holds in :data:`HEADER` with its batch of fixes
(:data:`NONE_HELD` before it has one). The server then adds :data:`ETAG_KEY` (the list's ETag
now) to the batch answer, and :data:`COMMANDS_KEY` (exactly the poll's ``commands``) only when
that ETag differs from the one sent. A post without the header is answered as it always was,
so an older boat sees no change; an answer without :data:`ETAG_KEY` comes from an older server,
and the boat keeps polling.

The commonest answer says nothing: every fix stored (or already there), none rejected, and
the list the boat holds still current. A boat that also sends ``Prefer: return=minimal``
(:data:`PREFER`, RFC 7240 §4.2) gets that answer as :data:`SETTLED` (204 No Content): no body
and no content headers, about 120 bytes fewer on every exchange of a boat that reports every
period. Opt-in, because a boat that sends only the ETag header (an edge client from before
the 204) reads every answer as JSON. Pure: both sides import it.
"""

from __future__ import annotations

from typing import Any

# A custom request header: If-None-Match would make the POST itself conditional (RFC 9110
# §13.1.2: a 412 instead of storing the fixes).
HEADER = "X-Commands-ETag"
# The header as Django's request.META names it.
META_KEY = "HTTP_X_COMMANDS_ETAG"
# "I hold no list yet": a valid entity-tag that no list ever has.
NONE_HELD = '""'
# A held ETag longer than this is no ETag of ours ('"c<vessel>.<version>"'): taken as none held.
MAX_HELD = 64
# The answer to a batch taken whole while the boat's list is current, for a boat that asks
# for minimal answers: nothing to say.
SETTLED = 204
PREFER_HEADER = "Prefer"
PREFER_META_KEY = "HTTP_PREFER"
PREFER = "return=minimal"
ETAG_KEY = "commands_etag"
COMMANDS_KEY = "commands"


def held_etag(value: str | None) -> str:
    """What the boat sends in :data:`HEADER`: the ETag it holds, or :data:`NONE_HELD`."""
    return value or NONE_HELD


def wants_minimal(prefer: str | None) -> bool:
    """Whether a ``Prefer`` header's value asks for ``return=minimal`` (preferences are
    comma-separated, each maybe with parameters after ``;``, names case-insensitive)."""
    if not prefer:
        return False
    for preference in prefer.split(","):
        token = preference.split(";", 1)[0].strip().lower().replace(" ", "")
        if token == PREFER:
            return True
    return False


def settled(answer: dict[str, Any]) -> bool:
    """Whether an exchange's answer (the batch answer with its exchange keys) may be
    :data:`SETTLED`: nothing rejected, and no list to send."""
    return not answer.get("rejected") and COMMANDS_KEY not in answer


def list_in_answer(answer: Any) -> tuple[str, list[Any] | None] | None:
    """(the list's ETag now, its commands or None when unchanged) from a telemetry answer, or
    None when the answer carries no exchange (an older server) or a malformed one."""
    if not isinstance(answer, dict):
        return None
    etag = answer.get(ETAG_KEY)
    if not isinstance(etag, str) or not etag:
        return None
    if COMMANDS_KEY not in answer:
        return etag, None
    commands = answer[COMMANDS_KEY]
    if not isinstance(commands, list):
        return None
    return etag, commands
