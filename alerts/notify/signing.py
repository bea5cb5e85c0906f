"""The webhook signature: HMAC-SHA256 over ``"<timestamp>.<raw body>"`` with the channel's secret.

Pure, stdlib only. Signing the timestamp with the body lets a receiver refuse a replayed request
(an old timestamp) as well as a forged one. A receiver does what :func:`verify` does; docs/alerts.md
("Checking a webhook's signature") shows it standalone.
"""

from __future__ import annotations

import hashlib
import hmac

TIMESTAMP_HEADER = "X-Shoreside-Timestamp"
SIGNATURE_HEADER = "X-Shoreside-Signature"
SCHEME = "sha256="
# How old a request a receiver should still take: clocks drift, and a retry is signed afresh.
MAX_AGE_S = 300


def signature(secret: str, timestamp: int, body: bytes) -> str:
    """``sha256=<hex>`` for ``body`` sent at ``timestamp`` (unix seconds)."""
    mac = hmac.new(secret.encode(), f"{timestamp}.".encode() + body, hashlib.sha256)
    return SCHEME + mac.hexdigest()


def headers(secret: str, timestamp: int, body: bytes) -> dict[str, str]:
    """The two headers a signed request carries."""
    return {
        TIMESTAMP_HEADER: str(timestamp),
        SIGNATURE_HEADER: signature(secret, timestamp, body),
    }


def verify(secret: str, timestamp: str, sent: str, body: bytes, *, now: float) -> bool:
    """True when ``sent`` signs ``body`` at ``timestamp`` and that is at most MAX_AGE_S old
    (or ahead: the sender's clock may run fast). Compares in constant time."""
    try:
        at = int(timestamp)
    except ValueError:
        return False
    if abs(now - at) > MAX_AGE_S:
        return False
    return hmac.compare_digest(signature(secret, at, body), sent)
