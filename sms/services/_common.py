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
