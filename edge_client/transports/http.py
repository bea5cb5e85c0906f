"""Plain HTTP(S) through ``requests``: for a Pi with a network interface (PPP, SLIP, Wi-Fi).

TLS certificates are always verified (optionally against ``ca_bundle``); there is no switch to
turn verification off. Every request has a timeout, and temporary failures are retried a bounded
number of times with exponential backoff (:func:`~edge_client.transports.base.with_retries`).
"""

from __future__ import annotations

import json
from typing import Any

import requests
from urllib3.util import SKIP_HEADER

from edge_client.transports.base import Response, TransportError, error_for_status, with_retries


class HttpTransport:
    def __init__(
        self,
        *,
        base_url: str,
        key: str,
        timeout_s: float = 20.0,
        retries: int = 2,
        backoff_s: float = 1.0,
        ca_bundle: str | None = None,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        self.timeout_s = timeout_s
        self.retries = retries
        self.backoff_s = backoff_s
        self.session = requests.Session()
        self.session.verify = ca_bundle if ca_bundle else True
        # Only the headers the server needs: on 3G every byte of every request is paid for.
        # requests' defaults add Accept, Accept-Encoding, Connection and a long User-Agent;
        # below them urllib3 adds its own User-Agent and http.client `Accept-Encoding:
        # identity` (what a request without one means anyway: RFC 9110 §12.5.3) unless told
        # to skip them. Left: Host, Authorization, Content-Type, Content-Length, and for
        # the poll If-None-Match. Keep-alive is HTTP/1.1's default: no Connection header.
        self.session.headers.clear()
        self.session.headers.update(
            {
                "Authorization": f"Api-Key {key}",
                "User-Agent": SKIP_HEADER,
                "Accept-Encoding": SKIP_HEADER,
            }
        )

    def post_json(self, path: str, body: Any, headers: dict[str, str] | None = None) -> Response:
        data = json.dumps(body, separators=(",", ":"), allow_nan=False).encode()
        return self.post_bytes(path, data, "application/json", headers)

    def post_bytes(
        self, path: str, data: bytes, content_type: str, headers: dict[str, str] | None = None
    ) -> Response:
        return self._request("POST", path, {"Content-Type": content_type, **(headers or {})}, data)

    def get(self, path: str, etag: str | None = None) -> Response:
        headers = {"If-None-Match": etag} if etag else {}
        return self._request("GET", path, headers, None)

    def close(self) -> None:
        self.session.close()

    def _request(self, method: str, path: str, headers: dict[str, str], data: bytes | None):
        url = self.base_url + path

        def attempt() -> Response:
            try:
                r = self.session.request(
                    method, url, headers=headers, data=data, timeout=self.timeout_s
                )
            except requests.exceptions.SSLError as exc:
                # A certificate problem will not fix itself between retries.
                raise TransportError(f"TLS error talking to {url}: {exc}", permanent=True) from exc
            except requests.RequestException as exc:
                raise TransportError(f"{method} {url}: {exc.__class__.__name__}: {exc}") from exc
            if r.status_code < 300 or r.status_code == 304:
                return Response(
                    status=r.status_code,
                    headers={k.lower(): v for k, v in r.headers.items()},
                    body=r.content,
                )
            raise error_for_status(r.status_code, r.content)

        return with_retries(attempt, retries=self.retries, backoff_s=self.backoff_s)
