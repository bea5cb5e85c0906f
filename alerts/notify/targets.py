"""A channel's target checked and put in its one form per kind: an e-mail address, a phone
number in E.164 (national numbers are read in SMS_DEFAULT_REGION, as for SMS control), or an
http(s) URL. Raises Django's ValidationError on ``target``, so the admin and the API show it."""

from __future__ import annotations

from django.core.exceptions import ValidationError
from django.core.validators import URLValidator, validate_email

from sms.errors import InvalidNumber
from sms.services import number_normalise

_URL = URLValidator(schemes=["http", "https"])


def clean_target(kind: str, target: str) -> str:
    """The target in its stored form (E.164 for a number), or ValidationError."""
    value = (target or "").strip()
    if not value:
        raise ValidationError({"target": "A channel needs a target."})
    try:
        if kind == "email":
            validate_email(value)
        elif kind == "sms":
            value = number_normalise(raw=value)
        elif kind == "webhook":
            _URL(value)
        else:
            raise ValidationError({"kind": f"{kind!r} is not a channel kind."})
    except InvalidNumber as exc:
        raise ValidationError({"target": str(exc)}) from None
    except ValidationError as exc:
        if hasattr(exc, "error_dict"):
            raise
        what = {"email": "an e-mail address", "webhook": "an http:// or https:// URL"}[kind]
        raise ValidationError({"target": f"{value!r} is not {what}."}) from None
    return value
