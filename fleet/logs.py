"""Vessel keys stay out of the logs.

The legacy SPAB client may only send its key as `?key=` (the F2414 modem cannot do Basic auth),
and a v1 request carrying one is refused but still logged. Every log line that can carry a
URL (Django's runserver and request loggers, gunicorn's access and error logs) passes through
`hide_keys`, which masks the value of any query parameter naming a key and anything shaped
like a vessel key (`ssk_…`), wherever it appears.
"""

from __future__ import annotations

import logging
import re
from urllib.parse import unquote_plus

from vessels.keys import KEY_PREFIX

HIDDEN = "[hidden]"

# A query string inside a line: from "?" to the next space or quote (a request line, a URL).
_QUERY_IN_TEXT = re.compile(r"\?([^\s\"'<>]*)")
_KEY_SHAPED = re.compile(re.escape(KEY_PREFIX) + r"[A-Za-z0-9_\-%]+")


def hide_query(query: str) -> str:
    """``query`` (without "?") with the value of every parameter whose name, decoded, names a
    key (`key`, `api_key`, `%6Bey`) masked; the other parameters stay for debugging."""
    parts = []
    for part in query.split("&"):
        name, eq, _value = part.partition("=")
        if eq and "key" in unquote_plus(name).lower():
            part = f"{name}={HIDDEN}"
        parts.append(part)
    return "&".join(parts)


def hide_keys(text: str) -> str:
    """``text`` with every key-carrying query parameter and every key-shaped string masked."""
    text = _QUERY_IN_TEXT.sub(lambda m: "?" + hide_query(m.group(1)), text)
    return _KEY_SHAPED.sub(KEY_PREFIX + HIDDEN, text)


class HideKeys(logging.Filter):
    """A logging filter (on a handler or a logger) that masks keys in the formatted message."""

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        hidden = hide_keys(message)
        if hidden != message:
            record.msg, record.args = hidden, None
        return True
