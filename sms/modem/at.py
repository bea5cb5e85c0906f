"""The AT dialogue of an SMS modem in text mode, without I/O: a line reader and parsers.

References: docs/sms.md, 'The GSM modem' (framing, set-up, receiving, sending, error codes);
3GPP TS 27.005 §3 (+CMGR, +CMGL, +CMTI, +CMGS, +CPMS, +CMS ERROR codes §3.2.5) and TS 27.007
§9.2 (+CME ERROR codes); ITU-T V.250 §5.7 (``<CR><LF>text<CR><LF>`` framing, final results).

:class:`AtReader` is fed the modem's bytes in any chunks and returns events:

* :class:`Response` — the answer to the command in flight: its information lines, the messages
  it carried (+CMGR/+CMGL) and the :class:`FinalResult` (``OK``, ``ERROR``, ``+CMS ERROR: n``,
  ``+CME ERROR: n``, numeric or verbose);
* :class:`Urc` — an unsolicited line (+CMTI, RING, +CREG, the power-up burst ``RDY``, ``+CFUN``,
  ``+CPIN``, ``SMS Ready`` …), which may arrive at any moment, also in the middle of an answer;
* :class:`Prompt` — the ``> `` that +CMGS prints (no line ending) when it wants the text;
* :class:`Echo` — our own command coming back (modems echo until ``ATE0``);
* :class:`Noise` — anything else (garbage, a late answer to a command given up on).

``feed`` never raises; the parsers below raise only :class:`~.errors.AtParseError`.

Text under ``AT+CSCS="GSM"`` is GSM-7, one byte per septet (``sms.gsm7``). A line is ended by
CR LF only: a lone LF is a line break inside an SMS text. After a +CMGR/+CMGL header the next
line is the message text whatever it looks like (``OK``, ``+CMTI: …``). With ``AT+CSDH=1`` the
header carries the text's length, so a text of several lines is read exactly; without it, the
text continues until an empty line, a final result, a new +CMGL header or a known URC.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta, timezone

from sms import gsm7

from .error_codes import describe_error, verbose_code
from .errors import AtParseError, ModemUsageError

CRLF = b"\r\n"
PROMPT = b"> "  # TS 27.005 §3.5.1: <CR><LF><greater_than><space>, then the modem waits
CTRL_Z = b"\x1a"  # ends the text: send it
ESC = b"\x1b"  # abandons the text
# Longest line we wait for: a +CMGL header with CSDH=1 is ~100 bytes, a text line ≤ 160 bytes
# (plus escapes); anything longer without CR LF is garbage and is reported in pieces.
MAX_LINE = 1024
QUARTER_HOUR = timedelta(minutes=15)  # TS 23.040 §9.2.3.11: the zone is in quarter hours

# V.250 §5.7.1 final result codes, plus the two SMS/equipment error forms.
_FINAL_WORDS = {"OK", "ERROR", "NO CARRIER", "BUSY", "NO ANSWER", "NO DIALTONE", "NO DIAL TONE"}
_ERROR_LINE = re.compile(r"^\+(CMS|CME) ERROR:\s*(.*)$", re.IGNORECASE)

# Unsolicited result codes (TS 27.005 §3.4.1, TS 27.007, and the power-up lines of Quectel and
# SIMCom modules). A URC is recognised by its name: the text before ':' or the whole line.
URC_NAMES = frozenset(
    {
        "+CMTI", "+CMT", "+CDSI", "+CDS", "+CBM", "+CBMI", "RING", "+CRING", "+CLIP", "+CCWA",
        "+CREG", "+CGREG", "+CEREG", "+CUSD", "+CIEV", "+CTZV", "+CTZE", "*PSUTTZ", "DST",
        "RDY", "START", "+CFUN", "+CPIN", "SMS READY", "CALL READY", "+QIND", "+QUSIM",
        "POWERED DOWN", "NORMAL POWER DOWN", "UNDER-VOLTAGE POWER DOWN",
        "UNDER-VOLTAGE WARNNING", "UNDER-VOLTAGE WARNING", "OVER-VOLTAGE POWER DOWN",
        "+PACSP", "PB DONE", "NO CARRIER",
    }
)  # fmt: skip
# Lines that mean the modem (re)started or became ready again: echo is back on, text mode off.
RESTART_LINES = frozenset(
    {"RDY", "START", "+CFUN: 1", "+CPIN: READY", "SMS READY", "CALL READY", "+QIND: SMS DONE"}
)
RECEIVED_STATES = ("REC UNREAD", "REC READ")

# -- events ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FinalResult:
    """The line that ends a command's answer. ``code`` is None for ``OK``/``ERROR``."""

    kind: str  # "OK", "ERROR", "+CMS ERROR", "+CME ERROR", "NO CARRIER", …
    code: int | None = None
    text: str = ""

    @property
    def ok(self) -> bool:
        return self.kind == "OK"

    @property
    def meaning(self) -> str:
        return describe_error(self.kind, self.code, self.text)[0]

    @property
    def temporary(self) -> bool:
        return describe_error(self.kind, self.code, self.text)[1]


@dataclass(frozen=True)
class ReceivedSms:
    """One stored message from +CMGR/+CMGL (or a pushed +CMT).

    ``index`` is the slot in ``storage`` (None when the header does not carry it: +CMGR, whose
    index the caller knows). ``timestamp`` is the service centre's, timezone-aware; None for
    messages we stored ourselves (``STO …``) or an unreadable stamp. ``key`` identifies one
    message across reads and restarts: the same number, text and modem timestamp.
    """

    index: int | None
    status: str
    number: str
    text: str
    timestamp: datetime | None
    storage: str = "SM"

    @property
    def received(self) -> bool:
        return self.status in RECEIVED_STATES

    @property
    def key(self) -> tuple[str, str, datetime | None]:
        return (self.number, self.text, self.timestamp)


@dataclass(frozen=True)
class Response:
    """A complete answer: information lines, messages carried, and the final result."""

    command: str
    lines: tuple[str, ...]
    messages: tuple[ReceivedSms, ...]
    result: FinalResult


@dataclass(frozen=True)
class Urc:
    """An unsolicited line. ``name`` is upper case (``+CMTI``, ``RDY``, ``SMS READY``)."""

    name: str
    text: str
    sms: ReceivedSms | None = None  # the message of a pushed +CMT (CNMI 2,2: not used here)

    @property
    def restart(self) -> bool:
        """The modem restarted or became ready again: set it up before the next command."""
        return self.text.upper() in RESTART_LINES


@dataclass(frozen=True)
class Prompt:
    """``> ``: the modem waits for the text of +CMGS (or +CMGW)."""


@dataclass(frozen=True)
class Echo:
    """Our own command line, echoed back (ATE1, the state after power-up)."""

    text: str


@dataclass(frozen=True)
class Noise:
    """A line that is neither an answer nor a URC: logged and dropped."""

    text: str
    reason: str


Event = Response | Urc | Prompt | Echo | Noise


# -- the reader -----------------------------------------------------------------------------------


@dataclass
class _Body:
    """A message header seen; its text lines are being collected."""

    kind: str  # "+CMGR", "+CMGL" or "+CMT"
    index: int | None
    status: str
    number: str
    timestamp: datetime | None
    length: int | None  # from CSDH=1: the text length announced in the header
    parts: list[bytes] = field(default_factory=list)

    def collected(self) -> int:
        return sum(len(p) for p in self.parts) + 2 * max(0, len(self.parts) - 1)

    def message(self) -> ReceivedSms:
        text = gsm7.decode(b"\r\n".join(self.parts))
        return ReceivedSms(self.index, self.status, self.number, text, self.timestamp)


class AtReader:
    """Incremental reader of the modem's byte stream (sans-I/O, h11 style).

    Call :meth:`start` with each command line just before writing it (one in flight at a
    time), then :meth:`feed` every chunk read; each call returns the events completed by it. The
    same bytes in any chunking give the same events. :meth:`cancel` forgets the command in flight
    (after a timeout): its late answer then shows up as :class:`Noise`.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self._command: str | None = None
        self._name = ""  # "+CMGR" for "AT+CMGR=3": lines "+CMGR: …" answer it
        self._prompt_wanted = False
        self._echoed = False
        self._lines: list[str] = []
        self._messages: list[ReceivedSms] = []
        self._body: _Body | None = None
        self.noise_lines = 0

    @property
    def command(self) -> str | None:
        """The command in flight, or None."""
        return self._command

    def start(self, command: str) -> None:
        """Announce ``command`` (without CR) as sent; raises ModemUsageError if one is pending."""
        if self._command is not None:
            raise ModemUsageError(f"{command!r} sent while {self._command!r} is in flight")
        self._command = command.strip()
        upper = self._command.upper()
        match = re.match(r"AT([+*#$^][A-Z0-9]+)", upper)
        self._name = match.group(1) if match else ""
        self._prompt_wanted = self._name in ("+CMGS", "+CMGW")
        self._echoed = False
        self._lines, self._messages = [], []

    def cancel(self) -> None:
        """Give up on the command in flight (its answer, if it comes, becomes Noise)."""
        self._command = None
        self._name = ""
        self._prompt_wanted = False
        self._body = None

    def feed(self, data: bytes) -> list[Event]:
        """Take more bytes; return the events they complete. Never raises."""
        self._buf += data
        events: list[Event] = []
        buf = self._buf
        while buf:
            if self._prompt_wanted and self._body is None and buf[:1] == b">":
                if len(buf) < len(PROMPT):
                    break  # one byte of a possible prompt: wait for the next
                if buf[:2] == PROMPT:
                    del buf[:2]
                    events.append(Prompt())
                    continue
            end = buf.find(CRLF, 0, MAX_LINE + 2)
            if end >= 0:
                line = bytes(buf[:end])
                del buf[: end + 2]
                self._line(line, events)
            elif len(buf) >= MAX_LINE + 2:
                chunk = bytes(buf[:MAX_LINE])
                del buf[:MAX_LINE]
                self._noise(chunk.decode("latin-1"), "line too long", events)
            else:
                break
        return events

    # -- one line -----------------------------------------------------------------------------

    def _line(self, raw: bytes, events: list[Event]) -> None:
        body = self._body
        if body is not None and self._take_body_line(body, raw, events):
            return
        text = raw.decode("latin-1").strip()
        if not text:
            return  # the empty half of <CR><LF>text<CR><LF> framing
        command = self._command
        if command is not None and not self._echoed and text.upper() == command.upper():
            self._echoed = True
            events.append(Echo(text))
            return
        final = parse_final(text)
        if final is not None and (command is not None or final.kind != "NO CARRIER"):
            if command is None:
                self._noise(text, "result with no command in flight", events)
                return
            events.append(Response(command, tuple(self._lines), tuple(self._messages), final))
            self.cancel()
            return
        name = _name_of(text)
        if command is not None and self._name and name == self._name:
            if name in ("+CMGR", "+CMGL"):
                self._header(text, events)
            else:
                self._lines.append(text)
            return
        if name in URC_NAMES:
            if name == "+CMT":
                self._cmt_header(text, events)
            else:
                events.append(Urc(name, text))
            return
        if command is not None:
            self._lines.append(text)  # e.g. the lines of ATI, or a garbled line (callers check)
        else:
            self._noise(text, "unsolicited line not understood", events)

    def _take_body_line(self, body: _Body, raw: bytes, events: list[Event]) -> bool:
        """Add ``raw`` to the message text if it belongs there; True if it did."""
        if not body.parts:
            body.parts.append(raw)  # the first line after a header is text, whatever it says
        elif body.length is not None:
            if body.collected() + 2 + len(raw) > body.length:
                self._finish_body(events)
                return False  # the announced length is reached: this line is not text
            body.parts.append(raw)
        else:
            text = raw.decode("latin-1").strip()
            name = _name_of(text)
            if not text or parse_final(text) or name in URC_NAMES or name == "+CMGL":
                self._finish_body(events)
                return not text
            body.parts.append(raw)
        if body.length is not None and body.collected() >= body.length:
            self._finish_body(events)
        elif body.kind == "+CMT" and body.length is None:
            self._finish_body(events)  # a URC cannot wait for a terminator: one line
        return True

    def _finish_body(self, events: list[Event]) -> None:
        body = self._body
        self._body = None
        if body is None:
            return
        message = body.message()
        if body.kind == "+CMT":
            events.append(Urc("+CMT", f"+CMT: {body.number}", message))
        else:
            self._messages.append(message)

    def _header(self, text: str, events: list[Event]) -> None:
        try:
            header = parse_message_header(text)
        except AtParseError:
            self._lines.append(text)
            return
        if header is None:
            self._lines.append(text)  # a status report: no text follows
            return
        self._body = header

    def _cmt_header(self, text: str, events: list[Event]) -> None:
        try:
            self._body = parse_message_header(text)
        except AtParseError:
            events.append(Urc("+CMT", text))

    def _noise(self, text: str, reason: str, events: list[Event]) -> None:
        self.noise_lines += 1
        events.append(Noise(text, reason))


# -- parsers --------------------------------------------------------------------------------------


def _name_of(text: str) -> str:
    """``+CMTI`` for ``+CMTI: "SM",3``; the whole line, upper case, when it has no ':'."""
    head, colon, _rest = text.partition(":")
    return head.strip().upper() if colon else text.strip().upper()


def parse_final(text: str) -> FinalResult | None:
    """The final result on ``text``, or None if it is not one (numeric and verbose errors)."""
    upper = text.strip().upper()
    if upper in _FINAL_WORDS:
        return FinalResult(upper, None, text)
    match = _ERROR_LINE.match(text.strip())
    if not match:
        return None
    kind = f"+{match.group(1).upper()} ERROR"
    detail = match.group(2).strip()
    if detail.isdigit():
        return FinalResult(kind, int(detail), text)
    return FinalResult(kind, verbose_code(kind, detail), text)


def split_fields(text: str) -> list[tuple[str, bool]]:
    """The comma-separated fields after ``+NAME:``, as (value, was_quoted); quotes may hold ','."""
    _name, _colon, rest = text.partition(":")
    fields: list[tuple[str, bool]] = []
    value: list[str] = []
    quoted = in_quotes = False
    for ch in rest:
        if in_quotes:
            if ch == '"':
                in_quotes = False
            else:
                value.append(ch)
        elif ch == '"':
            if not "".join(value).strip():
                value = []  # the space after ':' or ',' is not part of a quoted value
            in_quotes = quoted = True
        elif ch == ",":
            fields.append(("".join(value).strip() if not quoted else "".join(value), quoted))
            value, quoted = [], False
        else:
            value.append(ch)
    if in_quotes:
        raise AtParseError("unterminated quote", text)
    fields.append(("".join(value).strip() if not quoted else "".join(value), quoted))
    return fields


def _int(value: str, what: str, line: str) -> int:
    if not value.strip().isdigit():
        raise AtParseError(f"{what} is not a number", line)
    return int(value)


_SCTS = re.compile(r"^(\d\d)/(\d\d)/(\d\d),(\d\d):(\d\d):(\d\d)(?:([+-])(\d{1,2}))?$")


def parse_scts(text: str) -> datetime:
    """``yy/MM/dd,hh:mm:ss±zz`` (TS 27.005 §3.1 <scts>, zone in quarter hours) → aware datetime.

    A stamp without the zone (some firmware) is taken as UTC.
    """
    match = _SCTS.match(text.strip())
    if not match:
        raise AtParseError("not a yy/MM/dd,hh:mm:ss±zz time stamp", text)
    yy, month, day, hour, minute, second, sign, quarters = match.groups()
    offset = timedelta(0)
    if sign:
        offset = QUARTER_HOUR * int(quarters) * (-1 if sign == "-" else 1)
        if abs(offset) >= timedelta(hours=24):
            raise AtParseError("time zone out of range", text)
    try:
        return datetime(
            2000 + int(yy),
            int(month),
            int(day),
            int(hour),
            int(minute),
            int(second),
            tzinfo=timezone(offset) if offset else UTC,
        )
    except ValueError as exc:
        raise AtParseError(f"impossible time stamp ({exc})", text) from None


def parse_cmti(text: str) -> tuple[str, int]:
    """``+CMTI: "SM",3`` → ("SM", 3): a new message was stored at that index."""
    fields = split_fields(text)
    if _name_of(text) != "+CMTI" or len(fields) < 2:
        raise AtParseError("not a +CMTI indication", text)
    return fields[0][0], _int(fields[1][0], "index", text)


def parse_cmgs(text: str) -> int:
    """``+CMGS: 17`` → 17, the message reference (TP-MR, 0–255)."""
    fields = split_fields(text)
    if _name_of(text) != "+CMGS" or not fields:
        raise AtParseError("not a +CMGS answer", text)
    return _int(fields[0][0], "message reference", text)


@dataclass(frozen=True)
class StoreUsage:
    """One message store of +CPMS: ``memory`` is None in the answer to the set command."""

    memory: str | None
    used: int
    total: int


def parse_cpms(text: str) -> list[StoreUsage]:
    """``+CPMS: 3,30,3,30,3,30`` (set) or ``+CPMS: "SM",3,30,…`` (query) → usage per store."""
    if _name_of(text) != "+CPMS":
        raise AtParseError("not a +CPMS answer", text)
    fields = split_fields(text)
    named = bool(fields) and fields[0][1]
    step = 3 if named else 2
    if len(fields) % step:
        raise AtParseError("unexpected number of +CPMS fields", text)
    stores = []
    for i in range(0, len(fields), step):
        group = fields[i : i + step]
        memory = group[0][0] if named else None
        used, total = group[-2][0], group[-1][0]
        stores.append(StoreUsage(memory, _int(used, "used", text), _int(total, "total", text)))
    return stores


def parse_message_header(text: str) -> _Body | None:
    """A +CMGR/+CMGL/+CMT header → the message awaiting its text; None for a status report.

    Text-mode layouts (TS 27.005 §3.4.3, §4.1, §3.4.1), ``[…]`` present with ``AT+CSDH=1``:
    ``+CMGR: <stat>,<oa>,[<alpha>],<scts>[,<tooa>,<fo>,<pid>,<dcs>,<sca>,<tosca>,<length>]``,
    ``+CMGL: <index>,<stat>,<oa/da>,[<alpha>][,<scts>][,<tooa/toda>,<length>]``,
    ``+CMT: <oa>,[<alpha>],<scts>[,…,<length>]``; stored outgoing messages (``STO …``) have no
    <scts>. A status report has an unquoted <fo> where the number would be, and no text.
    """
    name = _name_of(text)
    fields = split_fields(text)
    index = None
    if name == "+CMGL":
        if len(fields) < 3:
            raise AtParseError("short +CMGL header", text)
        index = _int(fields[0][0], "index", text)
        fields = fields[1:]
    elif name == "+CMT":
        fields = [("REC UNREAD", True), *fields]
    elif name != "+CMGR":
        raise AtParseError("not a message header", text)
    if len(fields) < 2:
        raise AtParseError("short message header", text)
    status = fields[0][0].upper()
    if status.isdigit():
        raise AtParseError("a PDU-mode header (AT+CMGF=0)", text)
    number, number_quoted = fields[1]
    if not number_quoted and number.isdigit():
        return None  # SMS-STATUS-REPORT: <stat>,<fo>,<mr>,…
    timestamp = None
    base = 3  # stat, number, alpha
    if status.startswith("REC") or name == "+CMT":
        base = 4
        stamp = fields[3][0] if len(fields) > 3 else ""
        try:
            timestamp = parse_scts(stamp)
        except AtParseError:
            timestamp = None
    length = None
    last, last_quoted = fields[-1]
    if len(fields) > base and not last_quoted and last.isdigit():
        length = int(last)
    return _Body(name, index, status, number, timestamp, length)
