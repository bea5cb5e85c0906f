"""A shore command as one SMS in the glider's own language, and the reference that ties the SMS
to the shore command's uid (docs/links.md, 'Commands by SMS').

Pure: no Django, no I/O. The shore renders (:func:`render`); the glider reads the reference off
the end of an incoming text (:func:`split_reference`) and gives the rest to ``sms.language``
like any SMS, so the command is read by the same rules as a field user's.

The text is the command's SMS form with every value exact (a float is written with as many
digits as it needs to read back to the same number, not the 4 decimals of a reply's echo),
then a space and the reference::

    #WAYPOINT 1 -32.038 115.3325 ref:BN5FYHR7FVHIVHCBLVXH7AE2DPFP

The reference is ``ref:`` and 28 characters of the RFC 4648 base32 alphabet (A-Z, 2-7; read in
any case): the uid's 128 bits and a 12-bit check (the low bits of the CRC-32 of its bytes), 140
bits in all. A reference that does not check out is not a reference: it stays in the text, and
the language refuses it as an extra value, so a damaged SMS never runs under a wrong uid. All of
it is plain GSM-7 a text-mode modem can type (no ``@``, which is 0x00 there).
"""

from __future__ import annotations

import re
import uuid
import zlib
from collections.abc import Mapping
from decimal import Decimal
from typing import Any

from commands import catalog
from commands.errors import CatalogError
from edge_client.contract.kinds import WAVE_GLIDER
from sms import language
from sms.errors import NotSayable
from sms.gsm7 import SMS_SEPTETS, septets

# A command queued on the glider from its shore (by the shore link's poll, or by an SMS carrying
# a reference): its created_by and event actor. Its acks go up by uid; it is never reported up.
SHORE_CREATED_BY = "shore"

REF_MARK = "ref:"
ALPHABET = "ABCDEFGHIJKLMNOPQRSTUVWXYZ234567"
REF_CHARS = 28  # 140 bits: the uid's 128 and the check's 12
CHECK_BITS = 12
_BITS_PER_CHAR = 5
REFERENCE_LENGTH = len(REF_MARK) + REF_CHARS
# What a command keeps of one SMS: the rest is the space and the reference.
COMMAND_ROOM = SMS_SEPTETS - 1 - REFERENCE_LENGTH
_DIGIT = {c: i for i, c in enumerate(ALPHABET)}
_AT_END = re.compile(rf"(?:^|\s){re.escape(REF_MARK)}([A-Z2-7]{{{REF_CHARS}}})\s*\Z", re.IGNORECASE)


def _check(uid: uuid.UUID) -> int:
    return zlib.crc32(uid.bytes) & ((1 << CHECK_BITS) - 1)


def reference(uid: uuid.UUID) -> str:
    """``ref:`` and the uid with its check in base32 (28 characters)."""
    value = (uid.int << CHECK_BITS) | _check(uid)
    chars = []
    for _ in range(REF_CHARS):
        value, digit = divmod(value, 1 << _BITS_PER_CHAR)
        chars.append(ALPHABET[digit])
    return REF_MARK + "".join(reversed(chars))


def read_reference(token: str) -> uuid.UUID | None:
    """The uid of a reference (``ref:`` and its 28 characters, any case); None when ``token``
    is not one or its check fails."""
    if not token[: len(REF_MARK)].lower() == REF_MARK or len(token) != REFERENCE_LENGTH:
        return None
    value = 0
    for char in token[len(REF_MARK) :].upper():
        digit = _DIGIT.get(char)
        if digit is None:
            return None
        value = (value << _BITS_PER_CHAR) | digit
    uid = uuid.UUID(int=value >> CHECK_BITS)
    return uid if value & ((1 << CHECK_BITS) - 1) == _check(uid) else None


def split_reference(text: str) -> tuple[str, uuid.UUID | None]:
    """The text without a valid reference at its end, and the reference's uid (None when it
    carries none, or one that does not check out: then the text is returned whole)."""
    match = _AT_END.search(text)
    if match is None:
        return text, None
    uid = read_reference(REF_MARK + match.group(1))
    if uid is None:
        return text, None
    return text[: match.start()].rstrip(), uid


def _exact(value: float) -> str:
    """A float as positional digits that read back to exactly it (``repr``'s shortest digits,
    never an exponent, which a seaman would not read as a coordinate)."""
    return format(Decimal(repr(float(value))), "f")


def command_words(kind: str, params: Mapping[str, Any]) -> str:
    """The command alone in the glider's SMS language, every value exact; NotSayable when the
    glider has no SMS word for it or it is not a valid glider command."""
    return _words(kind, params)[0]


def _words(kind: str, params: Mapping[str, Any]) -> tuple[str, catalog.ValidCommand]:
    try:
        spec = catalog.get_kind(kind)
    except CatalogError as exc:
        raise NotSayable(exc.message) from None
    if spec.sms_word is None or WAVE_GLIDER not in spec.vessel_kinds:
        raise NotSayable(f"{kind}: a Wave Glider has no SMS word for it")
    try:
        valid = catalog.validate(kind, dict(params), vessel_kind=WAVE_GLIDER)
    except CatalogError as exc:
        raise NotSayable(f"{kind}: {exc.message}") from None
    parts = [f"#{spec.sms_word}"]
    for param in spec.params:
        value = valid.params[param.name]
        if param.kind == "indices":
            parts.extend(str(v) for v in value)
        elif param.kind == "choice":
            parts.append(str(value).upper())
        elif param.kind == "float":
            parts.append(_exact(value))
        else:
            parts.append(str(value))
    return " ".join(parts), valid


def render(kind: str, params: Mapping[str, Any], uid: uuid.UUID) -> str:
    """One SMS (at most 160 GSM-7 characters) saying the command and its reference.

    NotSayable names why not: no SMS word (a mission, a fence, a MAVLink kind), invalid for a
    glider, or too long for one SMS with its reference (a long ``#FCOURSE``). The text is read
    back through the glider's language before it is returned: what goes out is what runs.
    """
    words, valid = _words(kind, params)
    text = f"{words} {reference(uid)}"
    if septets(text) > SMS_SEPTETS:
        raise NotSayable(
            f"{kind}: too long for one SMS ({septets(words)} characters for the command, "
            f"{COMMAND_ROOM} at most with the reference)"
        )
    rest, read_uid = split_reference(text)
    items = language.parse(rest, vessel_kind=WAVE_GLIDER)
    if (
        read_uid != uid
        or len(items) != 1
        or items[0].kind != language.ItemKind.COMMAND
        or (items[0].command, dict(items[0].params)) != (valid.kind, valid.params)
    ):  # pragma: no cover - a bug here or in the language; the tests pin the two together
        raise NotSayable(f"{kind}: {words!r} would not read back as the same command")
    return text
