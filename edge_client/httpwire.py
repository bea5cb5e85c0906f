"""HTTP/1.1 on the wire, without I/O, for the F2414 modem transport.

References: RFC 9112 (HTTP/1.1 message syntax: §2.2 CRLF line endings, §3 request line, §4 status
line, §6 message body length: Content-Length, chunked, or read until the connection closes),
RFC 9110 §7.2 (Host is required in HTTP/1.1).

The modem is a transparent pipe (docs/edge-client.md): what we write after the ``don`` goes to
the server byte for byte, and the server's answer comes back in pieces of whatever size the serial
port hands us. :class:`ResponseParser` is fed those pieces and says when the answer is complete;
``close()`` tells it the bytes stopped (the server closed, or we gave up waiting) so that an
answer delimited by the connection's end is completed and one cut short is reported.
"""

from __future__ import annotations

from dataclasses import dataclass, field

CRLF = b"\r\n"
MAX_HEAD_BYTES = 16 * 1024  # a status line + headers larger than this is not our server


class HttpWireError(Exception):
    """The bytes from the server are not an HTTP/1.1 response we can use."""


class IncompleteResponse(HttpWireError):
    """The response stopped before its end (the modem link dropped mid-answer)."""


def build_request(
    method: str,
    host: str,
    path: str,
    headers: dict[str, str] | None = None,
    body: bytes = b"",
) -> bytes:
    """A complete HTTP/1.1 request: request line, headers and body, CRLF line endings.

    ``Host`` and ``Content-Length`` (for any body, and for POST/PUT even when empty) are always
    set; ``Connection: close`` because the modem link carries one exchange per connection.
    """
    if any(c in path for c in " \r\n") or not path.startswith("/"):
        raise ValueError(f"bad request target {path!r}")
    lines = [f"{method} {path} HTTP/1.1", f"Host: {host}"]
    merged = {"Connection": "close", **(headers or {})}
    if body or method in ("POST", "PUT", "PATCH"):
        merged["Content-Length"] = str(len(body))
    for name, value in merged.items():
        if any(c in f"{name}{value}" for c in "\r\n"):
            raise ValueError(f"header {name!r} contains a line break")
        lines.append(f"{name}: {value}")
    return ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1") + body


@dataclass
class ParsedResponse:
    status: int
    reason: str
    headers: dict[str, str]
    body: bytes


def _parse_status_line(line: str) -> tuple[int, str]:
    """``HTTP/1.x 200 OK`` → (200, "OK"); the reason phrase may be missing (RFC 9112 §4)."""
    parts = line.split(" ", 2)
    if len(parts) < 2 or not parts[0].startswith("HTTP/1.") or not parts[1].isdigit():
        raise HttpWireError(f"bad status line {line!r}")
    return int(parts[1]), parts[2] if len(parts) > 2 else ""


def _parse_header_lines(lines: list[str]) -> dict[str, str]:
    """Header fields by lower-case name; a repeated field's values are joined with ", "."""
    headers: dict[str, str] = {}
    for line in lines:
        name, sep, value = line.partition(":")
        if not sep or not name or name != name.strip():
            raise HttpWireError(f"bad header line {line!r}")
        key = name.lower()
        value = value.strip()
        headers[key] = f"{headers[key]}, {value}" if key in headers else value
    return headers


def _body_framing(status: int, headers: dict[str, str]) -> tuple[int | None, bool]:
    """(Content-Length, or None for "until the connection closes"; chunked?), RFC 9112 §6.3."""
    chunked = "chunked" in headers.get("transfer-encoding", "").lower()
    length = None
    if not chunked and "content-length" in headers:
        raw = headers["content-length"]
        if not raw.isdigit():
            raise HttpWireError(f"bad Content-Length {raw!r}")
        length = int(raw)
    if status in (204, 304) or 100 <= status < 200:
        return 0, False  # no body by definition (RFC 9112 §6.3 rule 1)
    return length, chunked


@dataclass
class ResponseParser:
    """Incremental parser: ``feed()`` bytes as they arrive, ``close()`` at end of input.

    ``response`` is set once the answer is complete. Anything before ``HTTP/`` (modem chatter
    such as a stray ``CONNECT`` line) is skipped and counted in ``skipped_bytes``.
    """

    response: ParsedResponse | None = None
    skipped_bytes: int = 0
    _buf: bytearray = field(default_factory=bytearray)
    _status: int = 0
    _reason: str = ""
    _headers: dict[str, str] | None = None
    _length: int | None = None  # Content-Length, or None = until close
    _chunked: bool = False
    _body: bytearray = field(default_factory=bytearray)
    _closed: bool = False

    @property
    def done(self) -> bool:
        return self.response is not None

    def feed(self, data: bytes) -> None:
        if self.done or not data:
            return
        if self._closed:
            raise HttpWireError("data after close()")
        self._buf += data
        self._advance()

    def close(self) -> ParsedResponse:
        """No more bytes will come. Returns the response or raises if it was cut short."""
        self._closed = True
        if self.done:
            assert self.response is not None
            return self.response
        if self._headers is None:
            if not self._buf and self._status == 0:
                raise IncompleteResponse("no response at all")
            raise IncompleteResponse("connection ended inside the response head")
        if self._chunked or self._length is not None:
            got = len(self._body) + (0 if self._chunked else len(self._buf))
            raise IncompleteResponse(
                f"connection ended after {got} body bytes"
                + ("" if self._chunked else f" of {self._length}")
            )
        # Body delimited by the end of the connection (RFC 9112 §6.3 rule 8).
        self._body += self._buf
        self._buf.clear()
        self._finish()
        assert self.response is not None
        return self.response

    def _advance(self) -> None:
        if self._headers is None and not self._parse_head():
            return
        if self._chunked:
            self._parse_chunks()
        elif self._length is not None:
            need = self._length - len(self._body)
            self._body += self._buf[:need]
            del self._buf[:need]
            if len(self._body) == self._length:
                self._finish()

    def _parse_head(self) -> bool:
        """Parse the status line and headers once all of them are in; False while not."""
        head = self._take_head()
        if head is None:
            return False
        status_line, *header_lines = head.split("\r\n")
        self._status, self._reason = _parse_status_line(status_line)
        self._headers = _parse_header_lines(header_lines)
        self._length, self._chunked = _body_framing(self._status, self._headers)
        return True

    def _take_head(self) -> str | None:
        """Skip chatter before ``HTTP/``; then remove and return the head up to its blank line."""
        start = self._buf.find(b"HTTP/")
        if start < 0:
            # Keep a possible partial "HTTP/" at the end; drop the rest as chatter.
            self._skip(max(0, len(self._buf) - len(b"HTTP")))
            return None
        self._skip(start)
        end = self._buf.find(CRLF + CRLF)
        if end < 0:
            if len(self._buf) > MAX_HEAD_BYTES:
                raise HttpWireError("response head too large")
            return None
        head = bytes(self._buf[:end]).decode("latin-1")
        del self._buf[: end + len(CRLF + CRLF)]
        return head

    def _skip(self, count: int) -> None:
        self.skipped_bytes += count
        del self._buf[:count]

    def _parse_chunks(self) -> None:
        # RFC 9112 §7.1: size in hex [;ext] CRLF, data CRLF, ..., 0 CRLF [trailers] CRLF
        while True:
            line_end = self._buf.find(CRLF)
            if line_end < 0:
                return
            size_text = bytes(self._buf[:line_end]).split(b";")[0].strip()
            try:
                size = int(size_text, 16)
            except ValueError:
                raise HttpWireError(f"bad chunk size {size_text!r}") from None
            if size == 0:
                # The last chunk's CRLF plus the (empty) trailer section's CRLF.
                if self._buf.find(CRLF + CRLF, line_end) < 0:
                    return
                self._buf.clear()
                self._finish()
                return
            start = line_end + 2
            if len(self._buf) < start + size + 2:
                return
            self._body += self._buf[start : start + size]
            del self._buf[: start + size + 2]

    def _finish(self) -> None:
        assert self._headers is not None
        self.response = ParsedResponse(
            status=self._status, reason=self._reason, headers=self._headers, body=bytes(self._body)
        )
