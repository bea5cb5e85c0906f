"""The Four-Faith F2414 3G modem as a transport (docs/edge-client.md#transports).

The modem is configured in TELNET + data-trigger mode: it idles until it sees the bytes ``don`` on
its serial port, then opens a TCP connection to the configured server and passes bytes through
unchanged in both directions; the server ends each exchange by closing the connection (HTTP/1.1
with ``Connection: close``). So one request is:

1. drop whatever is left in the input buffer from an earlier exchange;
2. write the trigger, give the modem ``connect_delay_s`` to dial;
3. write a complete HTTP/1.1 request (:func:`~edge_client.httpwire.build_request`) carrying the
   vessel key in ``Authorization: Api-Key`` (Basic auth never worked through it);
4. feed what comes back to :class:`~edge_client.httpwire.ResponseParser` until it is complete,
   the line goes quiet after data (the server closed: a serial port has no EOF), or the timeout.

The server host and port are set in the modem's own configuration; ``base_url`` here only gives
the ``Host`` header and the path prefix. There is no TLS on this path (the modem does plain TCP).
"""

from __future__ import annotations

import json
import logging
import time
from typing import Any
from urllib.parse import urlsplit

import serial

from edge_client.httpwire import HttpWireError, ResponseParser, build_request
from edge_client.transports.base import Response, TransportError, error_for_status, with_retries

log = logging.getLogger(__name__)

READ_CHUNK = 512
# After the answer started, this long without a byte means the server closed the connection.
QUIET_AFTER_DATA_S = 1.0


class ModemTransport:
    def __init__(
        self,
        *,
        base_url: str,
        key: str,
        port: str,
        baud: int = 115200,
        trigger: bytes = b"don",
        connect_delay_s: float = 1.0,
        timeout_s: float = 30.0,
        retries: int = 2,
        backoff_s: float = 1.0,
    ) -> None:
        parts = urlsplit(base_url)
        self.host = parts.netloc
        self.prefix = parts.path.rstrip("/")
        self.key = key
        self.port_url = port
        self.baud = baud
        self.trigger = trigger
        self.connect_delay_s = connect_delay_s
        self.timeout_s = timeout_s
        self.retries = retries
        self.backoff_s = backoff_s
        self._serial: serial.SerialBase | None = None

    def post_json(self, path: str, body: Any, headers: dict[str, str] | None = None) -> Response:
        data = json.dumps(body, separators=(",", ":"), allow_nan=False).encode()
        return self.post_bytes(path, data, "application/json", headers)

    def post_bytes(
        self, path: str, data: bytes, content_type: str, headers: dict[str, str] | None = None
    ) -> Response:
        return self._request("POST", path, {"Content-Type": content_type, **(headers or {})}, data)

    def get(self, path: str, etag: str | None = None) -> Response:
        return self._request("GET", path, {"If-None-Match": etag} if etag else {}, b"")

    def close(self) -> None:
        if self._serial is not None:
            self._serial.close()
            self._serial = None

    def _port(self) -> serial.SerialBase:
        if self._serial is None:
            try:
                self._serial = serial.serial_for_url(
                    self.port_url, baudrate=self.baud, timeout=0.1, write_timeout=self.timeout_s
                )
            except (serial.SerialException, OSError) as exc:
                raise TransportError(f"cannot open modem port {self.port_url}: {exc}") from exc
        return self._serial

    def _request(self, method: str, path: str, headers: dict[str, str], body: bytes) -> Response:
        request = build_request(
            method,
            self.host,
            self.prefix + path,
            # Only what the server needs (no User-Agent): every byte goes over paid 3G.
            {"Authorization": f"Api-Key {self.key}", **headers},
            body,
        )

        def attempt() -> Response:
            try:
                parsed = self._exchange(request)
            except (serial.SerialException, OSError) as exc:
                self.close()  # reopen next time: a USB modem may have re-enumerated
                raise TransportError(f"modem port {self.port_url}: {exc}") from exc
            except HttpWireError as exc:
                raise TransportError(f"modem exchange: {exc}") from exc
            if parsed.status < 300 or parsed.status == 304:
                return Response(parsed.status, parsed.headers, parsed.body)
            raise error_for_status(parsed.status, parsed.body)

        return with_retries(attempt, retries=self.retries, backoff_s=self.backoff_s)

    def _exchange(self, request: bytes):
        port = self._port()
        port.reset_input_buffer()
        port.write(self.trigger)
        port.flush()
        time.sleep(self.connect_delay_s)
        port.write(request)
        port.flush()
        parser = ResponseParser()
        deadline = time.monotonic() + self.timeout_s
        last_data: float | None = None
        while not parser.done:
            chunk = port.read(READ_CHUNK)
            now = time.monotonic()
            if chunk:
                parser.feed(chunk)
                last_data = now
                continue
            if last_data is not None and now - last_data > QUIET_AFTER_DATA_S:
                break  # the server closed; close() below completes or reports a cut-short answer
            if now > deadline:
                break
        if parser.skipped_bytes:
            log.debug(
                "modem: skipped %d bytes of chatter before the response", parser.skipped_bytes
            )
        return parser.close()
