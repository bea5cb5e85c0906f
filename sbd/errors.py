"""What the SBD app refuses, with the HTTP status the webhook answers it with."""

from __future__ import annotations


class SbdError(Exception):
    """Base of the SBD app's errors: ``code`` names it in the JSON answer."""

    status = 400
    code = "bad_request"

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class DeliveryError(SbdError):
    """A webhook field is missing or malformed."""

    def __init__(self, field: str, problem: str) -> None:
        super().__init__(f"{field}: {problem}")
        self.field = field


class NotConfigured(SbdError):
    """The webhook's public key is not set or cannot be read: nothing can be trusted."""

    status = 503
    code = "not_configured"


class SignatureRefused(SbdError):
    """No JWT, a bad one, an expired one, or one whose claims differ from the fields."""

    status = 403
    code = "bad_signature"


class UnknownImei(SbdError):
    """No vessel has this IMEI."""

    status = 404
    code = "unknown_imei"


class MtError(SbdError):
    """A mobile-terminated message was not taken by the provider; ``permanent``: trying
    again will not help (a bad IMEI, wrong credentials, a message too long)."""

    def __init__(self, message: str, *, permanent: bool = False) -> None:
        super().__init__(message)
        self.permanent = permanent
