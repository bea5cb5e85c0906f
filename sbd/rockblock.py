"""RockBLOCK's wire formats, pure: the delivery webhook's form fields (mobile-originated) and
the answer of its MT endpoint (mobile-terminated). No Django, no network (docs: doc-sbdhook).

A delivery is a form POST of ``imei``, ``momsn``, ``transmit_time`` ("21-10-31 10:41:50",
UTC), ``iridium_latitude``, ``iridium_longitude``, ``iridium_cep`` (km), ``data`` (the
payload in hex) and ``JWT``; the JWT is checked elsewhere (sbd/signing.py).
"""

from __future__ import annotations

import datetime as dt
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

from sbd.errors import DeliveryError, MtError

IMEI = re.compile(r"[0-9]{15}")
TIME_FORMAT = "%y-%m-%d %H:%M:%S"
MOMSN_MAX = 65535  # a 16-bit counter in the modem: it wraps
# A 9602/9603's largest mobile-originated message; anything longer is not from one.
MO_MAX_BYTES = 340
# The largest mobile-terminated message a 9602/9603 takes (AT+SBDWB's limit).
MT_MAX_BYTES = 270
FIELDS = (
    "imei",
    "momsn",
    "transmit_time",
    "iridium_latitude",
    "iridium_longitude",
    "iridium_cep",
    "data",
)
# RockBLOCK's MT error codes after which sending the same message again cannot succeed:
# bad credentials, an IMEI not on the account, no line rental, bad hex, too long, no data.
# 13 (no credit) and 99 (their system) may clear up, so they are tried again.
MT_PERMANENT_CODES = frozenset({"10", "11", "12", "14", "15", "16"})


@dataclass(frozen=True)
class Delivery:
    """One mobile-originated message as the provider delivered it."""

    imei: str
    momsn: int
    transmit_time: dt.datetime
    lat: float
    lon: float
    cep_km: float
    data: bytes


def _field(form: Mapping[str, str], name: str) -> str:
    value = form.get(name)
    if value is None:
        raise DeliveryError(name, "missing")
    return str(value).strip()


def _number(form: Mapping[str, str], name: str, lo: float, hi: float) -> float:
    raw = _field(form, name)
    try:
        value = float(raw)
    except ValueError:
        raise DeliveryError(name, f"{raw[:40]!r} is not a number") from None
    if not math.isfinite(value) or not lo <= value <= hi:
        raise DeliveryError(name, f"{raw[:40]} is not between {lo:g} and {hi:g}")
    return value


def parse_imei(raw: str) -> str:
    imei = raw.strip()
    if not IMEI.fullmatch(imei):
        raise DeliveryError("imei", "must be 15 digits")
    return imei


def parse_transmit_time(raw: str) -> dt.datetime:
    try:
        return dt.datetime.strptime(raw.strip(), TIME_FORMAT).replace(tzinfo=dt.UTC)
    except ValueError:
        raise DeliveryError("transmit_time", "must look like 21-10-31 10:41:50 (UTC)") from None


def parse_hex(raw: str, field: str = "data", limit: int = MO_MAX_BYTES) -> bytes:
    text = raw.strip()
    if len(text) > 2 * limit:
        raise DeliveryError(field, f"over {limit} bytes")
    try:
        return bytes.fromhex(text)
    except ValueError:
        raise DeliveryError(field, "is not hexadecimal") from None


def parse_delivery(form: Mapping[str, str]) -> Delivery:
    """The delivery in ``form``, every field checked; DeliveryError names the first bad one."""
    raw_momsn = _field(form, "momsn")
    if not raw_momsn.isdigit() or int(raw_momsn) > MOMSN_MAX:
        raise DeliveryError("momsn", f"must be a whole number 0 to {MOMSN_MAX}")
    return Delivery(
        imei=parse_imei(_field(form, "imei")),
        momsn=int(raw_momsn),
        transmit_time=parse_transmit_time(_field(form, "transmit_time")),
        lat=_number(form, "iridium_latitude", -90, 90),
        lon=_number(form, "iridium_longitude", -180, 180),
        cep_km=_number(form, "iridium_cep", 0, 20_000),
        data=parse_hex(_field(form, "data")),
    )


def parse_mt_answer(text: str) -> str:
    """The provider's message id from an MT answer ("OK,12345"); MtError on "FAILED,<code>,
    <text>" (permanent per MT_PERMANENT_CODES) or on anything else (temporary)."""
    answer = text.strip()
    head, _, rest = answer.partition(",")
    if head == "OK" and rest.strip():
        return rest.strip()
    if head == "FAILED":
        code, _, reason = rest.partition(",")
        code = code.strip()
        message = f"the provider refused the message: {code} {reason.strip()}".rstrip()
        raise MtError(message, permanent=code in MT_PERMANENT_CODES)
    raise MtError(f"the provider answered {answer[:80]!r}, not OK or FAILED")


CREDIT_BYTES = 50  # RockBLOCK bills a message by credits of 50 bytes, one at least


def credits(nbytes: int) -> int:
    """Credits a message of ``nbytes`` costs (an empty one still costs one)."""
    return max(1, -(-nbytes // CREDIT_BYTES))
