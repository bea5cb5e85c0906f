"""A shore command as one SMS in the glider's own language, and the signed reference that ties
the SMS to the shore command's uid (docs/links.md, 'Commands by SMS').

Pure: no Django, no I/O. The shore renders (:func:`render`); the glider takes the reference off
the end of an incoming text (:func:`split_reference`), checks it with its own key
(:func:`verified_uid`) and gives the rest to ``sms.language`` like any SMS, so the command is
read by the same rules as a field user's.

The text is the command's SMS form with every value exact (a float is written with as many
digits as it needs to read back to the same number, not the 4 decimals of a reply's echo),
then a space and the reference::

    #WAYPOINT 1 -32.038 115.3325 ref:N4OC2PQAABAABAAAAAAAAAFLZWIG6CGHFSLSVXDI

The reference is ``ref:`` and 40 characters of the RFC 4648 base32 alphabet (A-Z, 2-7; read in
any case): the uid's 128 bits and a 72-bit MAC, 200 bits in all. The MAC is HMAC-SHA256 keyed
with the SHA-256 of the vessel's key (the shore keeps only that hash; the glider hashes the key
its shore link presents), over the uid and the command's words before the reference (runs of
white space read as one space), cut to its first 72 bits. So only the shore and the glider can
make one, and a reference moved onto another command, or a command changed under its
reference, does not verify: at 72 bits, guessing one over SMS is hopeless. A reference that
does not verify is not one of ours, and the glider refuses the whole text. All of it is plain
GSM-7 a text-mode modem can type (no ``@``, which is 0x00 there).
"""

from __future__ import annotations

import hashlib
import hmac
import re
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
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
UID_BITS = 128
# 72 bits: a forger has one try per SMS (each one also logged on the glider); 2**72 of them
# is out of reach, and the reference still leaves most of an SMS to the command.
MAC_BITS = 72
REF_CHARS = 40  # 200 bits: the uid's 128 and the MAC's 72
_BITS_PER_CHAR = 5
REFERENCE_LENGTH = len(REF_MARK) + REF_CHARS
# What a command keeps of one SMS: the rest is the space and the reference.
COMMAND_ROOM = SMS_SEPTETS - 1 - REFERENCE_LENGTH
# Tells this MAC apart from any other use of the same key hash.
_MAC_CONTEXT = b"shoreside sms command reference v1\n"
_DIGIT = {c: i for i, c in enumerate(ALPHABET)}
# Any word starting with the mark at the end of a text: a reference, or one that is not ours.
_AT_END = re.compile(rf"(?:^|\s)({re.escape(REF_MARK)}\S*)\s*\Z", re.IGNORECASE)

assert REF_CHARS * _BITS_PER_CHAR == UID_BITS + MAC_BITS


@dataclass(frozen=True)
class Reference:
    """A reference as read off a text: the uid and the MAC it claims (not verified yet)."""

    uid: uuid.UUID
    mac: int


def _key(key_hash: str) -> bytes:
    """The MAC's key: the 32 bytes of a vessel key's SHA-256 (given as its 64 hex digits)."""
    raw = bytes.fromhex(key_hash)
    if len(raw) != hashlib.sha256().digest_size:
        raise ValueError("a vessel key hash is 64 hex digits (SHA-256)")
    return raw


def _canonical(words: str) -> bytes:
    return " ".join(words.split()).encode("utf-8", "surrogatepass")


def mac(uid: uuid.UUID, words: str, key_hash: str) -> int:
    """The reference's MAC of ``uid`` and the command's ``words`` under ``key_hash`` (hex of
    SHA-256 of the vessel key): the first :data:`MAC_BITS` of HMAC-SHA256. ValueError when
    ``key_hash`` is not 64 hex digits."""
    digest = hmac.new(_key(key_hash), _MAC_CONTEXT + uid.bytes + _canonical(words), hashlib.sha256)
    return int.from_bytes(digest.digest(), "big") >> (8 * digest.digest_size - MAC_BITS)


def reference(uid: uuid.UUID, words: str, key_hash: str) -> str:
    """``ref:`` and the uid with the MAC of it and ``words`` in base32 (40 characters)."""
    value = (uid.int << MAC_BITS) | mac(uid, words, key_hash)
    chars = []
    for _ in range(REF_CHARS):
        value, digit = divmod(value, 1 << _BITS_PER_CHAR)
        chars.append(ALPHABET[digit])
    return REF_MARK + "".join(reversed(chars))


def read_reference(token: str) -> Reference | None:
    """The uid and MAC of a reference (``ref:`` and its 40 characters, any case), unverified;
    None when ``token`` does not have that form (an old 28-character one, a damaged one)."""
    if not token[: len(REF_MARK)].lower() == REF_MARK or len(token) != REFERENCE_LENGTH:
        return None
    value = 0
    for char in token[len(REF_MARK) :].upper():
        digit = _DIGIT.get(char)
        if digit is None:
            return None
        value = (value << _BITS_PER_CHAR) | digit
    return Reference(uuid.UUID(int=value >> MAC_BITS), value & ((1 << MAC_BITS) - 1))


def split_reference(text: str) -> tuple[str, str | None]:
    """The text without the ``ref:…`` word at its end, and that word; ``(text, None)`` when
    the text does not end with one. The word is not checked here: see :func:`verified_uid`."""
    match = _AT_END.search(text)
    if match is None:
        return text, None
    return text[: match.start()].rstrip(), match.group(1)


def verified_uid(words: str, token: str, key_hash: str | None) -> uuid.UUID | None:
    """The uid of reference ``token`` that came after ``words``, when its MAC under
    ``key_hash`` is right; None when there is no key to check it with, the token is not a
    reference, or the MAC is wrong (made with another key, or the words were changed)."""
    ref = read_reference(token)
    if ref is None or not key_hash:
        return None
    expected = mac(ref.uid, words, key_hash).to_bytes(MAC_BITS // 8, "big")
    claimed = ref.mac.to_bytes(MAC_BITS // 8, "big")
    return ref.uid if hmac.compare_digest(expected, claimed) else None


def same_command(
    kind: str, params: Mapping[str, Any], other_kind: str, other_params: Mapping[str, Any]
) -> bool:
    """Whether two (kind, params) say the same glider command: compared as the catalog
    validates them (so ``[3, 4]`` and ``(3, 4)``, ``230`` and ``230.0`` are one), or as given
    when one of them does not validate."""
    if kind != other_kind:
        return False
    return _canonical_params(kind, params) == _canonical_params(kind, other_params)


def _canonical_params(kind: str, params: Mapping[str, Any]) -> dict[str, Any]:
    try:
        valid = dict(catalog.validate(kind, dict(params), vessel_kind=WAVE_GLIDER).params)
    except CatalogError:
        valid = dict(params)
    return {k: list(v) if isinstance(v, tuple | list) else v for k, v in valid.items()}


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


def render(kind: str, params: Mapping[str, Any], uid: uuid.UUID, key_hash: str) -> str:
    """One SMS (at most 160 GSM-7 characters) saying the command and its reference, signed
    with ``key_hash`` (hex of SHA-256 of the vessel key the glider's shore link presents).

    NotSayable names why not: no SMS word (a mission, a fence, a MAVLink kind), invalid for a
    glider, or too long for one SMS with its reference (a long ``#FCOURSE``). The text is read
    back as the glider reads it (reference verified, words through its language) before it is
    returned: what goes out is what runs.
    """
    words, valid = _words(kind, params)
    text = f"{words} {reference(uid, words, key_hash)}"
    if septets(text) > SMS_SEPTETS:
        raise NotSayable(
            f"{kind}: too long for one SMS ({septets(words)} characters for the command, "
            f"{COMMAND_ROOM} at most with the reference)"
        )
    rest, token = split_reference(text)
    items = language.parse(rest, vessel_kind=WAVE_GLIDER)
    if (
        token is None
        or verified_uid(rest, token, key_hash) != uid
        or len(items) != 1
        or items[0].kind != language.ItemKind.COMMAND
        or (items[0].command, dict(items[0].params)) != (valid.kind, valid.params)
    ):  # pragma: no cover - a bug here or in the language; the tests pin the two together
        raise NotSayable(f"{kind}: {words!r} would not read back as the same command")
    return text
