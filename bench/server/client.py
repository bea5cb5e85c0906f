"""Plain HTTP/1.1 requests to the server under test (127.0.0.1 only), outside of wrk."""

from __future__ import annotations

import http.client
import socket
import time

from bench.server.constants import HOST


def http_request(
    port: int,
    method: str,
    path: str,
    body: bytes | None = None,
    headers: dict[str, str] | None = None,
    timeout: float = 30,
) -> tuple[int, dict[str, str], bytes]:
    conn = http.client.HTTPConnection(HOST, port, timeout=timeout)
    try:
        conn.request(method, path, body=body, headers=headers or {})
        response = conn.getresponse()
        return response.status, dict(response.getheaders()), response.read()
    finally:
        conn.close()


def raw_response_head(port: int, request: bytes) -> bytes:
    """Send ``request`` on a raw socket; return the status line and headers, byte for byte."""
    with socket.create_connection((HOST, port), timeout=10) as s:
        s.sendall(request)
        data = b""
        deadline = time.monotonic() + 10
        while b"\r\n\r\n" not in data and time.monotonic() < deadline:
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
    head, sep, _ = data.partition(b"\r\n\r\n")
    return head + sep


def get_request(path: str, key: str = "", etag: str = "") -> bytes:
    lines = [f"GET {path} HTTP/1.1", f"Host: {HOST}"]
    if key:
        lines.append(f"Authorization: Api-Key {key}")
    if etag:
        lines.append(f"If-None-Match: {etag}")
    return ("\r\n".join(lines) + "\r\n\r\n").encode()
