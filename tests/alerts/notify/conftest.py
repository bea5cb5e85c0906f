"""Local servers the notification channels talk to in tests, as a user's would be: a small SMTP
server (the commands smtplib and Django's SMTP backend use), an HTTP receiver that checks the
webhook signature the way docs/alerts.md tells users to, and alert rows to notify about."""

from __future__ import annotations

import datetime as dt
import email
import email.policy
import hashlib
import hmac
import json
import socketserver
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from email.message import EmailMessage
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

from alerts.models import Alert, AlertRule, NotificationChannel
from alerts.services.notifications import notification_channel_create
from vessels.models import Vessel

BASE = dt.datetime(2026, 11, 28, 3, 12, tzinfo=dt.UTC)
SECRET = "correct-horse-battery-staple-0123456789"


# -- the receiver's side of the signature, as docs/alerts.md shows it -------------------------


def verify_shoreside(secret: str, headers: Any, body: bytes, now: float | None = None) -> bool:
    """A webhook receiver's check, standalone (only the standard library), as documented."""
    timestamp = headers.get("X-Shoreside-Timestamp", "")
    signature = headers.get("X-Shoreside-Signature", "")
    if not timestamp.isdigit() or abs((now or time.time()) - int(timestamp)) > 300:
        return False  # missing, or older than 5 minutes: a replay
    expected = hmac.new(
        secret.encode(), timestamp.encode() + b"." + body, hashlib.sha256
    ).hexdigest()
    return hmac.compare_digest(f"sha256={expected}", signature)


# -- an HTTP receiver --------------------------------------------------------------------------


@dataclass
class Received:
    path: str
    headers: dict[str, str]
    body: bytes
    signed: bool  # the signature checked out with the receiver's secret

    def json(self) -> Any:
        return json.loads(self.body)


@dataclass
class Receiver:
    """Records every POST; answers each with the next of ``answers`` (status, or status and
    headers), then 204; sleeps ``delay_s`` first when set."""

    secret: str = SECRET
    answers: list[Any] = field(default_factory=list)
    delay_s: float = 0.0
    received: list[Received] = field(default_factory=list)
    url: str = ""

    def __post_init__(self) -> None:
        self.lock = threading.Lock()

    def next_answer(self) -> tuple[int, dict[str, str]]:
        with self.lock:
            answer = self.answers.pop(0) if self.answers else 204
        return answer if isinstance(answer, tuple) else (answer, {})


def _handler(receiver: Receiver) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        def do_POST(self) -> None:  # noqa: N802 - http.server's name
            body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
            headers = dict(self.headers.items())
            signed = verify_shoreside(receiver.secret, self.headers, body)
            with receiver.lock:
                receiver.received.append(Received(self.path, headers, body, signed))
            if receiver.delay_s:
                time.sleep(receiver.delay_s)
            status, extra = receiver.next_answer()
            payload = b"" if status == 204 else f"answer {status}".encode()
            self.send_response(status)
            for name, value in extra.items():
                self.send_header(name, value)
            self.send_header("Content-Length", str(len(payload)))
            self.end_headers()
            self.wfile.write(payload)

        def log_message(self, *_args: Any) -> None:
            pass

    return Handler


@pytest.fixture
def receiver() -> Iterator[Receiver]:
    rec = Receiver()
    server = ThreadingHTTPServer(("127.0.0.1", 0), _handler(rec))
    server.daemon_threads = True
    rec.url = f"http://127.0.0.1:{server.server_address[1]}/hooks/shoreside"
    thread = threading.Thread(target=server.serve_forever, args=(0.05,), daemon=True)
    thread.start()
    yield rec
    server.shutdown()
    server.server_close()


# -- an SMTP server ----------------------------------------------------------------------------


@dataclass
class Smtp:
    """What the server received, and how it answers RCPT TO per address (e.g. 550, 451)."""

    host: str = "127.0.0.1"
    port: int = 0
    refuse: dict[str, int] = field(default_factory=dict)
    messages: list[EmailMessage] = field(default_factory=list)
    envelopes: list[tuple[str, list[str]]] = field(default_factory=list)


def _smtp_handler(smtp: Smtp) -> type[socketserver.StreamRequestHandler]:
    class Handler(socketserver.StreamRequestHandler):
        def reply(self, line: str) -> None:
            self.wfile.write(line.encode() + b"\r\n")

        def handle(self) -> None:
            self.reply("220 localhost ESMTP test server")
            sender, recipients = "", []
            while line := self.rfile.readline():
                verb = line.decode().strip().split(" ", 1)[0].upper()
                argument = line.decode().strip()[len(verb) :].strip()
                if verb == "EHLO":
                    self.reply("250-localhost")
                    self.reply("250 8BITMIME")
                elif verb in ("HELO", "NOOP"):
                    self.reply("250 OK")
                elif verb == "RSET":
                    sender, recipients = "", []
                    self.reply("250 OK")
                elif verb == "MAIL":
                    sender = argument.partition(":")[2].strip().strip("<>")
                    self.reply("250 OK")
                elif verb == "RCPT":
                    to = argument.partition(":")[2].strip().strip("<>")
                    code = smtp.refuse.get(to)
                    if code:
                        self.reply(f"{code} {to}: refused")
                    else:
                        recipients.append(to)
                        self.reply("250 OK")
                elif verb == "DATA":
                    self.reply("354 End data with <CR><LF>.<CR><LF>")
                    self.receive(sender, recipients)
                    self.reply("250 OK queued")
                elif verb == "QUIT":
                    self.reply("221 Bye")
                    return
                else:
                    self.reply("502 Command not implemented")

        def receive(self, sender: str, recipients: list[str]) -> None:
            lines = []
            while (line := self.rfile.readline()) not in (b".\r\n", b""):
                lines.append(line[1:] if line.startswith(b"..") else line)  # RFC 5321 §4.5.2
            message = email.message_from_bytes(b"".join(lines), policy=email.policy.default)
            smtp.messages.append(message)  # type: ignore[arg-type]
            smtp.envelopes.append((sender, list(recipients)))

    return Handler


@pytest.fixture
def smtp_server(settings: Any) -> Iterator[Smtp]:
    """A running SMTP server, and the site's mail settings pointing at it."""
    smtp = Smtp()
    server = socketserver.ThreadingTCPServer(("127.0.0.1", 0), _smtp_handler(smtp))
    server.daemon_threads = True
    smtp.port = server.server_address[1]
    thread = threading.Thread(target=server.serve_forever, args=(0.05,), daemon=True)
    thread.start()
    settings.EMAIL_BACKEND = "django.core.mail.backends.smtp.EmailBackend"
    settings.EMAIL_HOST, settings.EMAIL_PORT = smtp.host, smtp.port
    settings.EMAIL_USE_TLS = settings.EMAIL_USE_SSL = False
    settings.EMAIL_HOST_USER = settings.EMAIL_HOST_PASSWORD = ""
    settings.EMAIL_TIMEOUT = 5
    settings.DEFAULT_FROM_EMAIL = "Shoreside <alerts@shore.test>"
    yield smtp
    server.shutdown()
    server.server_close()


# -- alerts to notify about --------------------------------------------------------------------


def make_vessel(slug: str, name: str = "", period_s: int = 10) -> Vessel:
    return Vessel.objects.create(slug=slug, name=name or slug.upper(), telemetry_period_s=period_s)


def make_rule(name: str = "Overdue", *channels: NotificationChannel, kind: str = "overdue"):
    rule = AlertRule.objects.create(name=name, kind=kind, threshold=3)
    rule.channels.set(channels)
    return rule


def make_alert(rule: AlertRule, vessel: Vessel, *, detail: str = "silent 25 min (3 periods)",
               opened_at: dt.datetime = BASE, **fields: Any) -> Alert:  # fmt: skip
    return Alert.objects.create(
        rule=rule, vessel=vessel, kind=rule.kind, opened_at=opened_at, detail=detail, **fields
    )


def make_channel(
    kind: str, target: str, *, secret: str | None = None, name: str = ""
) -> NotificationChannel:
    """Through the service, as the admin and the API make them (the target normalised)."""
    channel, _secret = notification_channel_create(
        name=name or f"{kind} {target}", kind=kind, target=target, secret=secret, by="tester"
    )
    return channel
