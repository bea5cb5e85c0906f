"""The provider's side, as RockBLOCK does it: an RSA key pair (made here, with cryptography),
deliveries signed RS256 whose claims repeat the fields, posted as a form to the webhook; and a
local HTTP server standing in for its MT endpoint."""

from __future__ import annotations

import datetime as dt
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs

import jwt
import pytest
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric import rsa
from django.test import Client

from vessels.models import Vessel
from vessels.services import vessel_create

IMEI = "300434063839690"
URL = "/api/v1/sbd/rockblock/"
SENT = dt.datetime(2026, 11, 28, 10, 41, 50, tzinfo=dt.UTC)


def private_key() -> rsa.RSAPrivateKey:
    return rsa.generate_private_key(public_exponent=65537, key_size=2048)


def pem(key: rsa.RSAPrivateKey) -> bytes:
    return key.public_key().public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo
    )


_PROVIDER_KEY = private_key()  # once per run: 2048-bit keys take a moment to make


@dataclass
class Provider:
    """Signs deliveries with its private key; ``key_file`` holds the public half."""

    key: rsa.RSAPrivateKey
    key_file: Path
    momsn: int = 0

    def fields(self, payload: bytes = b"", **changes: Any) -> dict[str, str]:
        self.momsn += 1
        form = {
            "imei": IMEI,
            "momsn": str(self.momsn),
            "transmit_time": SENT.strftime("%y-%m-%d %H:%M:%S"),
            "iridium_latitude": "-32.0512",
            "iridium_longitude": "115.7421",
            "iridium_cep": "3.0",
            "data": payload.hex(),
        }
        form.update(changes)
        return form

    def sign(self, form: dict[str, str], key: Any = None, **claims: Any) -> str:
        payload = {**form, "iss": "Rock 7", "iat": int(dt.datetime.now(dt.UTC).timestamp())}
        payload.update(claims)
        return jwt.encode(payload, key or self.key, algorithm="RS256")

    def delivery(self, payload: bytes = b"", **changes: Any) -> dict[str, str]:
        form = self.fields(payload, **changes)
        return {**form, "JWT": self.sign(form)}


@pytest.fixture
def provider(tmp_path: Path, settings: Any) -> Provider:
    key_file = tmp_path / "rockblock.pem"
    key_file.write_bytes(pem(_PROVIDER_KEY))
    settings.SBD_ROCKBLOCK_PUBLIC_KEY_FILE = str(key_file)
    return Provider(_PROVIDER_KEY, key_file)


@pytest.fixture
def sbd_vessel(db: None) -> Vessel:
    return vessel_create(slug="spab-sbd", name="SPAB SBD", imei=IMEI, telemetry_period_s=600)


@pytest.fixture
def webhook() -> Client:
    return Client()


# -- the MT endpoint's stand-in: a real HTTP server on a local port -----------------------------


@dataclass
class MtEndpoint:
    """Records each form posted; answers with the next of ``answers`` ((status, text)), then
    "OK,<n>"."""

    answers: list[tuple[int, str]] = field(default_factory=list)
    posts: list[dict[str, str]] = field(default_factory=list)
    url: str = ""

    def answer(self) -> tuple[int, str]:
        if self.answers:
            return self.answers.pop(0)
        return 200, f"OK,{5000 + len(self.posts)}"


@pytest.fixture
def mt_endpoint() -> Iterator[MtEndpoint]:
    endpoint = MtEndpoint()

    class Handler(BaseHTTPRequestHandler):
        def do_POST(self) -> None:  # noqa: N802 (http.server's name)
            body = self.rfile.read(int(self.headers.get("Content-Length", 0))).decode()
            endpoint.posts.append({k: v[0] for k, v in parse_qs(body).items()})
            status, text = endpoint.answer()
            payload = text.encode()
            self.send_response(status)
            self.send_header("Content-Type", "text/plain")
            self.send_header("Content-Length", str(len(payload)))
            self.end_headers()
            self.wfile.write(payload)

        def log_message(self, *args: Any) -> None:
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    endpoint.url = f"http://127.0.0.1:{server.server_address[1]}/rockblock/MT"
    try:
        yield endpoint
    finally:
        server.shutdown()
        server.server_close()
