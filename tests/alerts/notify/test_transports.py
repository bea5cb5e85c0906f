"""Each transport against a local server of its kind: an SMTP server, an HTTP receiver that
checks the signature as the docs say, the GSM modem simulator through the real driver on a
pseudo-terminal, and an HTTP SMS gateway. What counts as permanent, what as temporary."""

from __future__ import annotations

import datetime as dt
import socket
from collections.abc import Iterator
from types import SimpleNamespace

import pytest

from alerts.notify import TransportError, messages
from alerts.notify.mail import EmailTransport
from alerts.notify.sms import GatewaySender, ModemSender, SmsTransport
from alerts.notify.webhook import WebhookTransport
from sms.modem import ModemConfig
from sms.modem.simulator import ModemServer, SimulatedModem
from tests.alerts.notify.conftest import SECRET, Receiver, Smtp

BASE = dt.datetime(2026, 11, 28, 3, 12, 7, tzinfo=dt.UTC)
NUMBER = "+61412345678"


def an_alert() -> SimpleNamespace:
    return SimpleNamespace(
        pk=12, vessel=SimpleNamespace(slug="spab", name="SPAB"),
        rule=SimpleNamespace(name="Overdue"), kind="overdue", state="open", opened_at=BASE,
        acknowledged_at=None, acknowledged_by="", resolved_at=None, detail="silent 25 min",
    )  # fmt: skip


MESSAGE = messages.single("alert.opened", an_alert())


def channel(target: str, secret: str = "") -> SimpleNamespace:
    return SimpleNamespace(target=target, secret=secret)


def error_of(call) -> TransportError:  # type: ignore[no-untyped-def]
    with pytest.raises(TransportError) as caught:
        call()
    return caught.value


# -- e-mail ------------------------------------------------------------------------------------


def test_an_email_reaches_the_smtp_server(smtp_server: Smtp) -> None:
    EmailTransport().send(channel("ops@shore.test"), MESSAGE)
    [mail] = smtp_server.messages
    assert smtp_server.envelopes == [("alerts@shore.test", ["ops@shore.test"])]
    assert mail["Subject"] == "[Shoreside] ALERT SPAB (spab): Overdue"
    assert mail["To"] == "ops@shore.test"
    assert mail["X-Shoreside-Event"] == "alert.opened"
    assert "Detail:        silent 25 min" in mail.get_content()


def test_a_recipient_refused_for_good_is_permanent_and_a_busy_one_temporary(
    smtp_server: Smtp,
) -> None:
    smtp_server.refuse = {"gone@shore.test": 550, "full@shore.test": 452}
    assert error_of(lambda: EmailTransport().send(channel("gone@shore.test"), MESSAGE)).permanent
    busy = error_of(lambda: EmailTransport().send(channel("full@shore.test"), MESSAGE))
    assert not busy.permanent and "452" in str(busy)
    assert smtp_server.messages == []


def test_no_mail_server_is_temporary(settings, unused_port: int) -> None:  # type: ignore[no-untyped-def]
    settings.EMAIL_BACKEND = "django.core.mail.backends.smtp.EmailBackend"
    settings.EMAIL_HOST, settings.EMAIL_PORT, settings.EMAIL_TIMEOUT = "127.0.0.1", unused_port, 2
    error = error_of(lambda: EmailTransport().send(channel("ops@shore.test"), MESSAGE))
    assert not error.permanent and "mail server" in str(error)


# -- webhook -----------------------------------------------------------------------------------


def test_a_webhook_arrives_signed_as_documented(receiver: Receiver) -> None:
    WebhookTransport(timeout_s=5).send(channel(receiver.url, SECRET), MESSAGE)
    [got] = receiver.received
    assert got.signed
    assert got.path == "/hooks/shoreside"
    assert got.headers["Content-Type"] == "application/json"
    assert got.headers["X-Shoreside-Event"] == "alert.opened"
    assert got.json() == MESSAGE.payload


def test_a_signature_made_with_another_secret_does_not_check_out(receiver: Receiver) -> None:
    WebhookTransport(timeout_s=5).send(channel(receiver.url, "another-secret-entirely"), MESSAGE)
    assert [r.signed for r in receiver.received] == [False]


@pytest.mark.parametrize(
    ("status", "permanent"),
    [(400, True), (401, True), (404, True), (410, True), (408, False), (429, False),
     (500, False), (502, False), (503, False)],
)  # fmt: skip
def test_4xx_is_permanent_except_408_and_429_and_5xx_temporary(
    receiver: Receiver, status: int, permanent: bool
) -> None:
    receiver.answers = [status]
    error = error_of(lambda: WebhookTransport(timeout_s=5).send(channel(receiver.url, SECRET),
                                                               MESSAGE))  # fmt: skip
    assert error.permanent is permanent
    assert f"answered {status}" in str(error)


def test_a_redirect_is_not_followed_and_needs_a_new_url(receiver: Receiver) -> None:
    receiver.answers = [(301, {"Location": "https://elsewhere.test/hook"})]
    error = error_of(lambda: WebhookTransport(timeout_s=5).send(channel(receiver.url, SECRET),
                                                               MESSAGE))  # fmt: skip
    assert error.permanent and "https://elsewhere.test/hook" in str(error)
    assert len(receiver.received) == 1


def test_a_slow_receiver_times_out_temporarily(receiver: Receiver) -> None:
    receiver.delay_s = 1.0
    error = error_of(lambda: WebhookTransport(timeout_s=0.2).send(channel(receiver.url, SECRET),
                                                                 MESSAGE))  # fmt: skip
    assert not error.permanent and "within 0.2 s" in str(error)


def test_nobody_listening_is_temporary(unused_port: int) -> None:
    url = f"http://127.0.0.1:{unused_port}/hook"
    error = error_of(lambda: WebhookTransport(timeout_s=2).send(channel(url, SECRET), MESSAGE))
    assert not error.permanent


# -- SMS ---------------------------------------------------------------------------------------


@pytest.fixture(params=["pty", "tcp:0"])
def modem(request: pytest.FixtureRequest) -> Iterator[tuple[SimulatedModem, ModemServer]]:
    """The simulator on a pseudo-terminal (a USB modem's tty) or TCP (a serial server)."""
    sim = SimulatedModem()
    with ModemServer(sim, request.param) as server:
        yield sim, server


def fast(url: str) -> ModemConfig:
    return ModemConfig(url, command_timeout_s=1, send_timeout_s=2, wake_timeout_s=0.3,
                       settle_s=0.05, relist_interval_s=None)  # fmt: skip


def test_an_sms_goes_out_through_the_modem_driver(modem) -> None:  # type: ignore[no-untyped-def]
    sim, server = modem
    transport = SmsTransport(ModemSender(fast(server.url)))
    transport.send(channel(NUMBER), MESSAGE)
    transport.send(channel("+61400000002"), messages.single("alert.resolved", an_alert()))
    transport.close()
    assert [(s.number, s.text) for s in sim.sent] == [
        (NUMBER, "ALERT spab 03:12Z Overdue: silent 25 min"),
        ("+61400000002", "CLEAR spab 03:12Z Overdue: silent 25 min"),
    ]
    assert sim.commands.count("ATE0") == 1  # one set-up for the pass, not one per SMS
    assert 'AT+CMGS="+61412345678"' in sim.commands


def test_the_networks_refusals_say_whether_to_retry(modem) -> None:  # type: ignore[no-untyped-def]
    sim, server = modem
    sender = ModemSender(fast(server.url))
    sim.faults.send_error = 21  # short message transfer rejected
    assert error_of(lambda: sender.send_sms(NUMBER, "x")).permanent
    sim.faults.send_error = 42  # congestion
    assert not error_of(lambda: sender.send_sms(NUMBER, "x")).permanent
    sender.send_sms(NUMBER, "third time")
    sender.close()
    assert [s.text for s in sim.sent] == ["third time"]


def test_two_senders_take_turns_on_one_modem_port() -> None:
    sim = SimulatedModem()
    with ModemServer(sim, "pty") as server:
        first, second = ModemSender(fast(server.url)), ModemSender(fast(server.url))
        first.send_sms(NUMBER, "first")  # holds the port (and its lock) until closed
        busy = error_of(lambda: second.send_sms(NUMBER, "second"))
        assert not busy.permanent and "cannot open" in str(busy)
        first.close()
        second = ModemSender(fast(server.url))  # the next pass
        second.send_sms(NUMBER, "second")
        second.close()
    assert [s.text for s in sim.sent] == ["first", "second"]


def test_a_modem_that_is_not_there_is_temporary(tmp_path) -> None:  # type: ignore[no-untyped-def]
    sender = ModemSender(fast(str(tmp_path / "ttyUSB9")))
    error = error_of(lambda: sender.send_sms(NUMBER, "x"))
    assert not error.permanent and "cannot open" in str(error)


def test_sms_without_a_modem_or_gateway_configured_is_permanent() -> None:
    error = error_of(lambda: SmsTransport(None).send(channel(NUMBER), MESSAGE))
    assert error.permanent and "ALERTS_SMS_MODEM_URL" in str(error)


def test_the_gateway_gets_the_documented_request(receiver: Receiver) -> None:
    SmsTransport(GatewaySender(receiver.url, "gw-token", timeout_s=5)).send(
        channel(NUMBER), MESSAGE
    )
    [got] = receiver.received
    assert got.headers["Authorization"] == "Bearer gw-token"
    assert got.headers["Content-Type"] == "application/json"
    assert got.json() == {"to": NUMBER, "text": "ALERT spab 03:12Z Overdue: silent 25 min"}


def test_a_gateway_refusal_is_permanent_and_its_outage_temporary(receiver: Receiver) -> None:
    sender = GatewaySender(receiver.url, "wrong", timeout_s=5)
    receiver.answers = [401, 503]
    assert error_of(lambda: sender.send_sms(NUMBER, "x")).permanent
    assert not error_of(lambda: sender.send_sms(NUMBER, "x")).permanent


@pytest.fixture
def unused_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]
