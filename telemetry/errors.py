"""The telemetry app's errors (pure). Per-fix problems are not errors: ingest reports them by
index and keeps the good fixes; these are problems with a request as a whole."""

from __future__ import annotations


class TelemetryError(ValueError):
    """A telemetry request that cannot be taken at all; the message says why."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class BatchTooLarge(TelemetryError):
    def __init__(self, *, limit: int, got: int) -> None:
        # Say which limit, or the old client's operator chases a shape problem.
        super().__init__(f"At most {limit} fixes per request (got {got}).")
        self.limit = limit
        self.got = got


class KeyRefused(TelemetryError):
    """The vessel key a post was authenticated with was revoked (or its vessel deactivated)
    after its lookup: nothing was written. The view answers it as the key lookup would."""

    def __init__(self) -> None:
        super().__init__("This vessel key no longer works.")
