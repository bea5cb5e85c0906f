"""What every SMS service shares: the stored lengths, the cleaning of unstorable text, and
the written-out reads of the SMS path."""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Sequence
from typing import Any

from django.db import connection

from sms.models import AuthorisedNumber, SmsMessage

# Longer texts are stored cut (and refused whole by the language, which reads MAX_TEXT).
TEXT_STORE_MAX = 4000
DETAIL_MAX = 200
# NUL and the UTF-16 surrogate range: PostgreSQL cannot store either as text.
_UNSTORABLE = re.compile("[\x00\ud800-\udfff]")


# The three reads every SMS makes, written out: each is one indexed lookup, and the ORM's
# building of them (not the database) was most of the time an SMS took (bench.sms).
_SMS = connection.ops.quote_name(SmsMessage._meta.db_table)
_NUMBERS = connection.ops.quote_name(AuthorisedNumber._meta.db_table)
_ALLOWED = connection.ops.quote_name(AuthorisedNumber.vessels.through._meta.db_table)


def _scalar(sql: str, params: Sequence[object]) -> Any:
    """The first column of the first row, or None when there is no row."""
    with connection.cursor() as cursor:
        cursor.execute(sql, params)
        row = cursor.fetchone()
    return None if row is None else row[0]


def _stamp(when: dt.datetime) -> Any:
    return connection.ops.adapt_datetimefield_value(when)


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
