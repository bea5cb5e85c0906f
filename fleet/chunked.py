"""A request body sent with ``Transfer-Encoding: chunked`` is read, not taken as empty.

Django reads exactly ``CONTENT_LENGTH`` bytes of ``wsgi.input``, and a chunked request has no
Content-Length: its body read as empty, so a boat's telemetry batch was answered as if it held
nothing. WSGI (PEP 3333) gives the application no way to find a chunked body's end except the
server's ``wsgi.input_terminated`` promise (gunicorn and mod_wsgi make it, having de-chunked the
body themselves): reading to EOF is then safe. This wraps the WSGI application:

1. A chunked body without a Content-Length, behind a server that promises the end, is read into
   memory up to ``DATA_UPLOAD_MAX_MEMORY_SIZE`` + 1 bytes and handed on with the length of what
   was read. A longer body thus meets the usual 413, in the shape its view answers errors
   (``{"error": "too_large"}``, a legacy ``telemAck``), its rest never read.
2. Behind a server that makes no such promise (``runserver``'s wsgiref passes the chunk framing
   through), the body cannot be found: 411 Length Required, saying so, rather than a silent
   empty body.
"""

from __future__ import annotations

import io
import json
from collections.abc import Callable, Iterable
from typing import Any

from django.conf import settings

WSGIApp = Callable[[dict[str, Any], Callable[..., Any]], Iterable[bytes]]
READ_BLOCK = 64 * 1024
LENGTH_REQUIRED_DETAIL = (
    "This server cannot read a chunked request body here: send it with a Content-Length."
)


def is_chunked_without_length(environ: dict[str, Any]) -> bool:
    """True for a request whose body is chunked and whose length nobody declared."""
    if environ.get("CONTENT_LENGTH"):
        return False
    codings = environ.get("HTTP_TRANSFER_ENCODING", "")
    return "chunked" in [c.strip().lower() for c in codings.split(",")]


def read_bounded(stream: Any, limit: int | None) -> bytes:
    """All of ``stream`` up to EOF, or its first ``limit`` + 1 bytes when it is longer."""
    parts: list[bytes] = []
    size = 0
    while limit is None or size <= limit:
        want = READ_BLOCK if limit is None else min(READ_BLOCK, limit + 1 - size)
        block = stream.read(want)
        if not block:
            break
        parts.append(block)
        size += len(block)
    return b"".join(parts)


class ChunkedBodyMiddleware:
    """WSGI middleware: see the module docstring."""

    def __init__(self, app: WSGIApp) -> None:
        self.app = app

    def __call__(self, environ: dict[str, Any], start_response: Callable[..., Any]) -> Any:
        if is_chunked_without_length(environ):
            if not environ.get("wsgi.input_terminated"):
                return self.length_required(start_response)
            body = read_bounded(environ["wsgi.input"], settings.DATA_UPLOAD_MAX_MEMORY_SIZE)
            environ["wsgi.input"] = io.BytesIO(body)
            environ["CONTENT_LENGTH"] = str(len(body))
        return self.app(environ, start_response)

    @staticmethod
    def length_required(start_response: Callable[..., Any]) -> list[bytes]:
        # The API's one error shape (fleet.api), built by hand: Django has not started yet.
        body = json.dumps({"error": "length_required", "detail": LENGTH_REQUIRED_DETAIL}).encode()
        start_response(
            "411 Length Required",
            [("Content-Type", "application/json"), ("Content-Length", str(len(body)))],
        )
        return [body]
