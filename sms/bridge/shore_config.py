"""The glider's shore link configuration (issue 11 §6): where the shore is, how often to talk.

Pure (no Django, no I/O): read from a mapping of environment variables, so the bridge can take
the same values from its options. No URL or no key means no link at all.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field

# ShoreConfig field ← environment variable (seconds).
_PERIODS = (
    ("timeout_s", "WG_SHORE_TIMEOUT_S"),
    ("push_period_s", "WG_SHORE_PUSH_PERIOD_S"),
    ("poll_period_s", "WG_SHORE_POLL_PERIOD_S"),
    ("numbers_period_s", "WG_SHORE_NUMBERS_PERIOD_S"),
    ("sms_period_s", "WG_SHORE_SMS_PERIOD_S"),
)


@dataclass(frozen=True)
class ShoreConfig:
    """Where the shore is and how often to talk to it (environment: see :meth:`from_env`)."""

    url: str
    key: str = field(repr=False)  # a secret: never in a log line or a traceback
    outbox_path: str = ""  # empty: OUTBOX_NAME in the data folder (settings.DATA_DIR)
    ca_bundle: str | None = None
    timeout_s: float = 20.0
    push_period_s: float = 10.0
    poll_period_s: float = 20.0
    numbers_period_s: float = 300.0
    sms_period_s: float = 60.0
    batch_size: int = 100
    max_backoff_s: float = 300.0
    # An outgoing SMS still pending after this long goes up as pending (the modem may be gone).
    sms_pending_grace_s: float = 600.0

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> ShoreConfig | None:
        """The config from WG_SHORE_* variables; None when no URL and key are set (no link)."""
        env = os.environ if environ is None else environ
        url, key = env.get("WG_SHORE_URL", "").strip(), env.get("WG_SHORE_KEY", "").strip()
        if not url or not key:
            return None
        number: dict[str, float] = {}
        for name, var in _PERIODS:
            raw = env.get(var, "").strip()
            if not raw:
                continue
            try:
                number[name] = float(raw)
            except ValueError:
                raise ValueError(f"{var}={raw!r} is not a number of seconds") from None
            if not number[name] > 0:
                raise ValueError(f"{var}={raw!r} must be more than 0 seconds")
        return cls(
            url=url,
            key=key,
            outbox_path=env.get("WG_SHORE_OUTBOX", "").strip() or cls.outbox_path,
            ca_bundle=env.get("WG_SHORE_CA_BUNDLE", "").strip() or None,
            **number,
        )
