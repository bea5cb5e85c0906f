"""E-mail through Django's mail settings (EMAIL_HOST, EMAIL_PORT, … in docs/configuration.md).

SMTP's own split decides what is permanent (RFC 5321 §4.2.1): a 5xx refusal of the recipient
or of the message will be refused again; a 4xx, a dropped connection or a timeout may pass
later. A refusal of our own sender or login is the site's configuration, not the message's: it
stays temporary, so fixing the settings within the retries still delivers it.
"""

from __future__ import annotations

import smtplib
from typing import Any

from django.conf import settings
from django.core.mail import EmailMessage, get_connection

from .base import Message, TransportError


def _permanent(code: int | None) -> bool:
    return code is not None and 500 <= code < 600


class EmailTransport:
    def send(self, channel: Any, message: Message) -> None:
        mail = EmailMessage(
            subject=message.subject,
            body=message.body,
            from_email=settings.DEFAULT_FROM_EMAIL,
            to=[channel.target],
            headers={"X-Shoreside-Event": message.event},
            connection=get_connection(fail_silently=False),
        )
        try:
            sent = mail.send()
        except smtplib.SMTPRecipientsRefused as exc:
            codes = [code for code, _text in exc.recipients.values()]
            refused = "; ".join(f"{to}: {code} {_text(text)}" for to, (code, text) in
                                exc.recipients.items())  # fmt: skip
            raise TransportError(f"recipient refused: {refused}",
                                 permanent=all(_permanent(c) for c in codes)) from None  # fmt: skip
        except smtplib.SMTPDataError as exc:
            reason = f"message refused: {exc.smtp_code} {_text(exc.smtp_error)}"
            raise TransportError(reason, permanent=_permanent(exc.smtp_code)) from None
        except (smtplib.SMTPException, OSError) as exc:
            raise TransportError(f"mail server: {exc.__class__.__name__}: {exc}") from None
        if sent != 1:
            raise TransportError("the mail backend sent nothing", permanent=True)

    def close(self) -> None:
        pass


def _text(raw: bytes | str) -> str:
    return raw.decode(errors="replace") if isinstance(raw, bytes) else str(raw)
