"""The GSM 7-bit default alphabet (3GPP TS 23.038 §6.2.1): lengths, checks and the text-mode codec.

Pure, stdlib only. Used on both sides of the modem: replies are built to fit one SMS of 160
septets (``septets``, ``to_gsm7``), and with ``AT+CSCS="GSM"`` a modem in text mode exchanges
text as one byte per septet (``encode``/``decode``), where ``@`` is 0x00 and ``_`` 0x11, not
ASCII. Reference: docs/sms.md#the-gsm-modem-smsmodem (Sending).
"""

from __future__ import annotations

import unicodedata

# One SMS in text mode: 160 septets (TS 23.038; 140 octets of 7-bit packed user data).
SMS_SEPTETS = 160
ESCAPE = 0x1B

# The default alphabet, code point = index. 0x1B is the escape to the extension table.
BASIC = (
    "@£$¥èéùìòÇ\nØø\rÅåΔ_ΦΓΛΩΠΨΣΘΞ\x1bÆæßÉ"
    " !\"#¤%&'()*+,-./0123456789:;<=>?"
    "¡ABCDEFGHIJKLMNOPQRSTUVWXYZÄÖÑÜ§"
    "¿abcdefghijklmnopqrstuvwxyzäöñüà"
)
# The extension table: each of these costs two septets (escape + code).
EXTENSION = {"\f": 0x0A, "^": 0x14, "{": 0x28, "}": 0x29, "\\": 0x2F, "[": 0x3C, "~": 0x3D,
             "]": 0x3E, "|": 0x40, "€": 0x65}  # fmt: skip

_BASIC_CODE = {ch: i for i, ch in enumerate(BASIC) if i != ESCAPE}
_EXTENSION_CHAR = {code: ch for ch, code in EXTENSION.items()}
# Common characters from phones and keyboards that have a faithful GSM-7 spelling.
_SUBSTITUTES = {"‘": "'", "’": "'", "‚": "'", "“": '"', "”": '"', "„": '"', "–": "-", "—": "-",
                "…": "...", "°": " deg", "\t": " ", "`": "'", "´": "'"}  # fmt: skip


class Gsm7Error(ValueError):
    """Text that the GSM 7-bit default alphabet cannot carry (``encode``)."""


def is_gsm7(text: str) -> bool:
    """True when every character is in the default alphabet or its extension table."""
    return all(ch in _BASIC_CODE or ch in EXTENSION for ch in text)


def septets(text: str) -> int:
    """Septets ``text`` takes in one SMS (extension characters take two). Assumes ``is_gsm7``."""
    return len(text) + sum(1 for ch in text if ch in EXTENSION)


def to_gsm7(text: str, replacement: str = "?") -> str:
    """``text`` spelled in the GSM-7 alphabet, so a reply never switches the SMS to UCS-2.

    Quotes and dashes get their plain forms, accented letters outside the alphabet lose the
    accent (``ł`` → ``l`` where Unicode can decompose it), anything else becomes ``replacement``.
    """
    out: list[str] = []
    for ch in text:
        if ch in _BASIC_CODE or ch in EXTENSION:
            out.append(ch)
        elif ch in _SUBSTITUTES:
            out.append(_SUBSTITUTES[ch])
        else:
            base = unicodedata.normalize("NFKD", ch)
            kept = "".join(c for c in base if c in _BASIC_CODE or c in EXTENSION)
            out.append(kept if kept and not unicodedata.combining(base[0]) else replacement)
    return "".join(out)


def encode(text: str) -> bytes:
    """Unpacked septets, one byte each, as a text-mode modem under ``AT+CSCS="GSM"`` takes them."""
    out = bytearray()
    for ch in text:
        code = _BASIC_CODE.get(ch)
        if code is not None:
            out.append(code)
        elif ch in EXTENSION:
            out += bytes((ESCAPE, EXTENSION[ch]))
        else:
            raise Gsm7Error(f"{ch!r} is not in the GSM 7-bit alphabet")
    return bytes(out)


def decode(data: bytes) -> str:
    """The inverse of ``encode``; bytes above 0x7F and unknown escapes become ``?``."""
    out: list[str] = []
    escaped = False
    for byte in data:
        if escaped:
            # TS 23.038: an unknown extension code shows as the basic character (or a space).
            out.append(_EXTENSION_CHAR.get(byte, BASIC[byte] if byte < 0x80 else "?"))
            escaped = False
        elif byte == ESCAPE:
            escaped = True
        else:
            out.append(BASIC[byte] if byte < 0x80 else "?")
    if escaped:
        out.append(" ")
    return "".join(out)


# A long SMS is sent as segments, each losing a 6-byte header (TS 23.040 §9.2.3.24.1):
# 153 septets a segment in GSM-7, 67 UTF-16 units in UCS-2 (70 alone).
UCS2_UNITS = 70
SEGMENT_SEPTETS = 153
SEGMENT_UCS2_UNITS = 67


def on_air(text: str) -> tuple[int, int]:
    """(user-data bytes, segments) ``text`` costs as an SMS: GSM-7 septets packed 8 to 7 bytes
    when the alphabet carries it, else UCS-2 (two bytes per UTF-16 unit). An empty SMS is
    one segment of no bytes."""
    if is_gsm7(text):
        n = septets(text)
        nbytes = -(-n * 7 // 8)
        return nbytes, 1 if n <= SMS_SEPTETS else -(-n // SEGMENT_SEPTETS)
    units = len(text.encode("utf-16-le")) // 2
    return units * 2, 1 if units <= UCS2_UNITS else -(-units // SEGMENT_UCS2_UNITS)
