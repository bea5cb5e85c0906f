"""What every SMS service shares: the stored lengths, the cleaning of unstorable text, and
the checked save."""

from __future__ import annotations

from sms.models import SmsMessage

# Longer texts are stored cut (and refused whole by the language, which reads MAX_TEXT).
TEXT_STORE_MAX = 4000
DETAIL_MAX = 200


# Checked by the database instead (full_clean would read each one back): the foreign keys are
# rows or ids the services set themselves.
_RELATIONS = ["vessel", "authorised_number", "reply_to"]


def _save_checked(message: SmsMessage) -> SmsMessage:
    """Save ``message`` after the model's field checks (lengths, choices, blanks): every
    SmsMessage the services write goes through here. Without a query: the foreign keys are
    left out (see _RELATIONS), and the constraints (sms_status_for_outgoing_only, the unique
    keys) are the database's, which refuses a row that breaks one."""
    message.full_clean(exclude=_RELATIONS, validate_unique=False, validate_constraints=False)
    message.save()
    return message
