"""When a time a vessel sends can be believed: the one plausibility rule for every upload
(fixes, reported commands, the SMS log), here at the bottom layer so each app can use it."""

from __future__ import annotations

import datetime as dt

UTC = dt.UTC
# No vessel of this fleet reported before the original SPAB system existed (2018).
PLAUSIBLE_FROM = dt.datetime(2018, 1, 1, tzinfo=UTC)


def check_plausible(when: dt.datetime, *, now: dt.datetime, max_future_s: float) -> None:
    """Raise ValueError unless ``when`` is within [PLAUSIBLE_FROM, now + max_future_s]."""
    if when < PLAUSIBLE_FROM:
        raise ValueError(f"is before {PLAUSIBLE_FROM:%Y-%m-%d}")
    if (when - now).total_seconds() > max_future_s:
        raise ValueError(f"is more than {int(max_future_s)} s in the future (check the clock)")
