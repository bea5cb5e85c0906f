"""API request limits: a boat by its vessel, an operator by their user (DRF throttles).

Both sit in REST_FRAMEWORK's DEFAULT_THROTTLE_CLASSES, so they apply to the boat views as
well (these set only their own authentication). A throttled request is a 429 with
Retry-After; the API's exception handler gives it the usual {"error": "throttled", …} body.
"""

from __future__ import annotations

from typing import Any

from django.core.exceptions import ImproperlyConfigured
from rest_framework.request import Request
from rest_framework.settings import api_settings
from rest_framework.throttling import SimpleRateThrottle

from vessels.auth import BoatPrincipal


class WindowRateThrottle(SimpleRateThrottle):
    """A counter per fixed window (cache.add, then cache.incr): O(1) per request.

    DRF's SimpleRateThrottle keeps the time of every request in the window and rewrites that
    whole list on each one (600 entries for a busy boat, on every poll). A fixed window lets a
    burst straddling its edge reach twice the rate, which is fine for abuse control.
    """

    wait_s: float | None = None

    def get_rate(self) -> str | None:
        # Read at call time: DRF binds THROTTLE_RATES to the class when it is imported.
        try:
            return api_settings.DEFAULT_THROTTLE_RATES[self.scope]
        except KeyError:
            raise ImproperlyConfigured(f"No throttle rate for {self.scope!r}") from None

    def allow_request(self, request: Request, view: Any) -> bool:
        if self.rate is None:
            return True
        key = self.get_cache_key(request, view)
        if key is None:
            return True
        now = self.timer()
        window = int(now // self.duration)
        key = f"{key}:{window}"
        rest = (window + 1) * self.duration - now  # of this window, in seconds
        # incr() first: past a window's first request the key is there, and one cache call
        # counts it (add() failed, then incr() and touch() ran: the throttles were 6% of a
        # single-fix post's Python, profiled with bench.server). incr() is atomic in locmem,
        # get-then-set in the file and database caches, where a race may lose a count.
        try:
            count = self.cache.incr(key)
        except ValueError:  # the window's first request, or its key just expired
            count = 1 if self.cache.add(key, 1, self.duration) else self._incr_or_start(key)
        else:
            if not self._incr_keeps_to(rest):
                self.cache.touch(key, max(1, rest))
        if count <= self.num_requests:
            return True
        self.wait_s = rest
        return False

    def _incr_or_start(self, key: str) -> int:
        """Count on a key another process added meanwhile, or start it if it expired."""
        try:
            return self.cache.incr(key)
        except ValueError:
            self.cache.set(key, 1, self.duration)
            return 1

    def _incr_keeps_to(self, rest: float) -> bool:
        """Whether the key incr() leaves lives the window's ``rest`` seconds out.

        The locmem cache's incr() keeps the key's expiry; the file and database caches' re-set
        the key with the cache's default timeout (300 s unless configured), which outlives a
        /min window but not an /hour or /day one: those get their rest back with touch().
        The database cache keeps expiries to the whole second: hence the second's margin.
        """
        timeout = self.cache.default_timeout
        return timeout is None or rest <= timeout - 1

    def wait(self) -> float | None:
        return self.wait_s


class BoatRateThrottle(WindowRateThrottle):
    """Requests per vessel, whichever of its keys the boat uses (THROTTLE_BOAT_RATE)."""

    scope = "boat"

    def get_cache_key(self, request: Request, view: Any) -> str | None:
        if not isinstance(request.user, BoatPrincipal):
            return None
        return f"throttle:boat:{request.user.vessel.pk}"


class OperatorRateThrottle(WindowRateThrottle):
    """Requests per operator, by session or token (THROTTLE_OPERATOR_RATE)."""

    scope = "operator"

    def get_cache_key(self, request: Request, view: Any) -> str | None:
        user = request.user
        if user is None or isinstance(user, BoatPrincipal) or not user.is_authenticated:
            return None
        return f"throttle:operator:{user.pk}"
