"""The transports the settings ask for, one per channel kind (docs/configuration.md, Alerts)."""

from __future__ import annotations

from django.conf import settings

from .base import Transport
from .mail import EmailTransport
from .sms import GatewaySender, ModemSender, SmsSender, SmsTransport
from .webhook import WebhookTransport


def sms_sender_from_settings() -> SmsSender | None:
    """The modem when ALERTS_SMS_MODEM_URL is set, else the gateway, else None (settings
    refuse both at once)."""
    if settings.ALERTS_SMS_MODEM_URL:
        return ModemSender(settings.ALERTS_SMS_MODEM_URL)
    if settings.ALERTS_SMS_GATEWAY_URL:
        return GatewaySender(
            settings.ALERTS_SMS_GATEWAY_URL,
            settings.ALERTS_SMS_GATEWAY_TOKEN,
            timeout_s=settings.ALERTS_HTTP_TIMEOUT_S,
        )
    return None


def transports_from_settings() -> dict[str, Transport]:
    """``{kind: transport}`` for one sending pass; close each when the pass is over."""
    return {
        "email": EmailTransport(),
        "webhook": WebhookTransport(timeout_s=settings.ALERTS_HTTP_TIMEOUT_S),
        "sms": SmsTransport(sms_sender_from_settings()),
    }
