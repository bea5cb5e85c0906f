"""The SMS command language of the Wave Glider: texts in, parsed items and one-SMS replies out.

References: docs/sms.md#the-language (the words); replies are composed from the parsed objects,
as in the original glider software, whose field trials took ``#HOLDWP 1`` as ``#HOLD`` (the reply
to ``#FSEQ 1 1 4`` came back as ``#FSEQ 1 1``); the command catalog is the one rule set;
3GPP TS 23.038 through ``sms.gsm7`` (one SMS is 160 septets).

Pure: no Django, no I/O. The command words, parameters and ranges are the command catalog's
(``commands.catalog``: ``split_text``, ``parse_words``, ``to_text``); this module adds only what
is SMS-specific:

* several commands per SMS, one per line or separated by ``;`` (at most ``MAX_COMMANDS``);
  identical ones are taken once (``_merge_repeats``);
* a catalog word with no values is a query (``#LIGHT``); ``#STATUS`` and ``#HELP [word]``;
* coordinates as seamen write them (see ``_coordinates``): decimal degrees ``-32.0380 115.3325``
  or ``32.0380S 115.3325E``; degrees and decimal minutes ``32 02.28S 115 19.95E``,
  ``-32 02.280 115 19.950`` or ``32°02.28'S 115°19.95'E``;
* the glider's inner command table, passed in (``table``): a command the glider cannot carry
  out as configured is refused at once (``#FSEQ 1 1 4 ERR not enabled on this glider``);
* replies that echo the normalised command with every value and fit one SMS of GSM-7 text,
  shortened on purpose at field boundaries (``+2 more``) when they cannot.

Words match whole (``#HOLDWP 1`` is never ``#HOLD``, ``#IRX`` is unknown), in any case, with any
spacing. Nothing here raises on any text: every problem becomes an ``error`` item naming it.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import StrEnum
from typing import TYPE_CHECKING, Any

from commands import catalog
from commands.errors import CatalogError
from edge_client.contract import fix as fix_shape
from sms.gsm7 import SMS_SEPTETS, septets, to_gsm7
from sms.level2.errors import CommandRefused

if TYPE_CHECKING:
    from sms.level2.inner import InnerCommandTable

# Several commands fit one SMS; more than this is a mistake or an attack, not an order.
MAX_COMMANDS = 10
# Ten concatenated SMS parts of 160 characters. A longer text is refused whole, never cut: a cut
# could turn "#FHEAD 230" into a valid "#FHEAD 23".
MAX_TEXT = 1600
STATUS, HELP = "STATUS", "HELP"
SEPARATOR = "; "
# What a reply of several answers keeps free for the note on the answers left out
# ("; +10 more (10 ERR)").
NOTE_ROOM = 20
# What one answer keeps free for its echo when its outcome is too long ("#FCOURSE +9 more").
ECHO_ROOM = 24
NOT_ENABLED = "not enabled on this glider"
NOT_SUPPORTED = "not supported on this glider"


class ItemKind(StrEnum):
    COMMAND = "command"  # a valid order for the vessel: to be queued
    QUERY = "query"  # a command word alone: answered from the vessel's known state
    STATUS = "status"
    HELP = "help"
    ERROR = "error"  # refused; ``error`` says why


@dataclass(frozen=True, slots=True)
class Item:
    """One command or query of an SMS as understood.

    ``echo`` is the normalised text with every value (``#FSEQ 1 1 4``), or the text as typed
    when it could not be understood. ``commanding`` marks what asks the vessel to act (a
    control-role right), refused or not.
    """

    kind: ItemKind
    echo: str
    command: str = ""  # the catalog kind (commands, queries, refused commands; help topics)
    params: Mapping[str, Any] = field(default_factory=dict)
    error: str = ""
    answer: str = ""  # what the language answers by itself (#HELP)
    commanding: bool = False
    repeats: int = 1  # a command given this many times in the SMS, taken once

    def as_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {"kind": self.kind.value, "text": self.echo}
        if self.command:
            data["command"] = self.command
        if self.params:
            data["params"] = dict(self.params)
        if self.error:
            data["error"] = self.error
        if self.repeats > 1:
            data["repeats"] = self.repeats
        return data


@dataclass(frozen=True, slots=True)
class Answer:
    """One part of a reply: the echo of what was asked and its outcome (``QUEUED``, ``ON``)."""

    echo: str
    outcome: str
    error: bool = False
    note: str = ""  # said after the outcome, whatever it becomes ("(12 identical … once)")

    @property
    def said(self) -> str:
        """The outcome as the reply gives it, with the note."""
        return f"{self.outcome} {self.note}" if self.note else self.outcome


# -- parsing ----------------------------------------------------------------------------------


def parse(
    text: str,
    *,
    vessel_kind: str = catalog.WAVE_GLIDER,
    table: InnerCommandTable | None = None,
) -> list[Item]:
    """The items of one SMS, in order. Never raises: a problem is an ``error`` item.

    1. A text over ``MAX_TEXT`` characters, or with nothing in it, is one error.
    2. Lines and ``;`` separate commands; blank ones are skipped; past ``MAX_COMMANDS`` the
       rest are refused together.
    3. Each command is read by the catalog (:func:`_parse_command`) and, when ``table`` is
       given, checked against the glider's inner command table.
    """
    if len(text) > MAX_TEXT:
        return [_error("", f"message too long ({len(text)} characters; at most {MAX_TEXT})")]
    segments = [s for line in text.splitlines() for s in line.split(";") if s.strip()]
    if not segments:
        return [_error("", "empty message; send #HELP for the commands")]
    if len(segments) <= MAX_COMMANDS:  # most SMS: a few commands, each parsed
        parsed = [_parse_command(s, vessel_kind, table) for s in segments]
    else:  # one parse per distinct text: a flood of one command costs one (MAX_TEXT bounds it)
        seen: dict[str, Item] = {}
        parsed = []
        for segment in segments:
            key = " ".join(segment.split())
            if key not in seen:
                seen[key] = _parse_command(segment, vessel_kind, table)
            parsed.append(seen[key])
    if len(parsed) == 1:
        return parsed
    return _merge_repeats(parsed)


def _identity(item: Item) -> tuple[str, str] | None:
    """What makes two commands identical (kind and exact params); None for anything else.

    The catalog builds a kind's params in one order, so their repr compares them exactly
    (floats to the last digit: the echo's 4 decimals could join two different positions).
    """
    if item.kind != ItemKind.COMMAND:
        return None
    return item.command, repr(item.params)


def _merge_repeats(parsed: Sequence[Item]) -> list[Item]:
    """The items read from one SMS, identical commands taken once (issue 16 §6: twelve
    ``#HOLD`` made ten commands, nine of them superseded at once).

    1. The first ``MAX_COMMANDS`` distinct items, by first appearance, are read; the rest are
       refused together (``3 more not read``). A repeat of a command read is not counted.
    2. A command given several times stands once, where it was given last, with ``repeats``
       saying how often: the SMS still ends where it asked (``#LIGHT ON; #LIGHT OFF; #LIGHT
       ON`` leaves the light on; ``#HOLD; #FHEAD 230; #HOLD`` holds).
    3. Queries, #STATUS, #HELP and refusals are never merged: each is answered where it stands.
    """
    if len(parsed) <= MAX_COMMANDS:
        # Identical commands have the same echo: different echoes, nothing to merge.
        echoes = [item.echo for item in parsed if item.kind == ItemKind.COMMAND]
        if len(set(echoes)) == len(echoes):
            return list(parsed)
    keys = [_identity(item) for item in parsed]
    counts: dict[tuple[str, str], int] = {}
    last: dict[tuple[str, str], int] = {}
    read: set[int] = set()  # indices of the first appearances read
    not_read = 0
    for index, key in enumerate(keys):
        if key is not None and key in counts:
            counts[key] += 1
            last[key] = index
            continue
        if key is not None:
            counts[key], last[key] = 1, index
        if len(read) < MAX_COMMANDS:
            read.add(index)
        elif key is None:
            not_read += 1  # an unread command is counted below, with its repeats
    read_keys = {keys[i] for i in read} - {None}
    items: list[Item] = []
    for index, (item, key) in enumerate(zip(parsed, keys, strict=True)):
        if key is None:
            if index in read:
                items.append(item)
        elif key in read_keys and last[key] == index:
            items.append(item if counts[key] == 1 else replace(item, repeats=counts[key]))
    not_read += sum(n for key, n in counts.items() if key not in read_keys)
    if not_read:
        items.append(_error("", f"{not_read} more not read: at most {MAX_COMMANDS} per SMS"))
    return items


def _error(echo: str, reason: str, **kwargs: Any) -> Item:
    return Item(ItemKind.ERROR, echo, error=reason, **kwargs)


def _parse_command(segment: str, vessel_kind: str, table: InnerCommandTable | None) -> Item:
    try:
        word, args = catalog.split_text(segment)
    except CatalogError as exc:
        return _error(" ".join(segment.split()), exc.message)
    echo = " ".join([f"#{word}", *args])
    if word == STATUS:
        return Item(ItemKind.STATUS, echo) if not args else _error(echo, "#STATUS takes no values")
    if word == HELP:
        return _parse_help(echo, args, vessel_kind, table)
    try:
        spec = catalog.sms_kind(word)
    except CatalogError as exc:
        return _error(echo, exc.message)
    commanding = bool(args) or not spec.params
    if vessel_kind not in spec.vessel_kinds:
        reason = f"#{word} is not available on {vessel_kind} vessels"
        return _error(echo, reason, command=spec.name, commanding=commanding)
    if not commanding:
        return Item(ItemKind.QUERY, echo, command=spec.name)
    try:
        valid = catalog.parse_words(word, _coordinates(spec, args), vessel_kind=vessel_kind)
    except CatalogError as exc:
        return _error(echo, exc.message, command=spec.name, commanding=True)
    echo = catalog.to_text(valid.kind, valid.params)
    reason = table_refusal(table, valid.kind, valid.params) if table is not None else None
    kind, error = (ItemKind.ERROR, reason) if reason else (ItemKind.COMMAND, "")
    return Item(kind, echo, valid.kind, valid.params, error=error, commanding=True)


def table_refusal(table: InnerCommandTable, kind: str, params: Mapping[str, Any]) -> str | None:
    """Why the glider's inner command table cannot carry out a valid command, or None.

    The table, not the catalog, knows what this glider can do: provisional entries stay
    disabled until someone tests them against hardware (sms/level2/inner_commands.toml).
    """
    spec = table.commands.get(kind)
    if spec is None:
        return NOT_SUPPORTED
    if not spec.usable:
        return NOT_ENABLED
    try:
        table.check_valid(kind, params)
    except CommandRefused as exc:
        return exc.reason
    return None


def _parse_help(
    echo: str, args: Sequence[str], vessel_kind: str, table: InnerCommandTable | None
) -> Item:
    if len(args) > 1:
        return _error(echo, "#HELP takes one word at most (#HELP FSEQ)")
    topic = args[0].upper().lstrip("#") if args else ""
    echo = "#HELP"  # the answer starts with the word it explains
    if topic in ("", STATUS, HELP):
        return Item(ItemKind.HELP, echo, answer=_help_words(vessel_kind, table, topic))
    spec = catalog.SMS_WORDS.get(topic)
    if spec is None:
        return _error(echo, f"unknown command #{topic}")
    return Item(ItemKind.HELP, echo, command=spec.name, answer=_help_kind(spec, vessel_kind, table))


def _usable(spec: catalog.CommandKind, vessel_kind: str, table: InnerCommandTable | None) -> bool:
    if vessel_kind not in spec.vessel_kinds:
        return False
    entry = table.commands.get(spec.name) if table is not None else None
    return table is None or (entry is not None and entry.usable)


def _help_words(vessel_kind: str, table: InnerCommandTable | None, topic: str) -> str:
    if topic == STATUS:
        return "position and its age, battery, navigation mode, pending commands"
    words = [f"#{w}" for w, k in catalog.SMS_WORDS.items() if _usable(k, vessel_kind, table)]
    return " ".join([*words, "#STATUS"]) + ". A word alone asks its state. #HELP word: values"


def _help_kind(spec: catalog.CommandKind, vessel_kind: str, table: InnerCommandTable | None) -> str:
    usage = " ".join([f"#{spec.sms_word}", *(p.name for p in spec.params)])
    text = f"{usage}: {spec.label}"
    if not _usable(spec, vessel_kind, table):
        text += f" ({NOT_ENABLED})" if vessel_kind in spec.vessel_kinds else " (not on this vessel)"
    details = ", ".join(f"{p.name} {p.help}" for p in spec.params)
    return f"{text}. {details}" if details else text


# -- coordinates ------------------------------------------------------------------------------

_COORDINATE_MARKS = re.compile("[°º]")
_MINUTE_MARKS = re.compile("['′]")
_ANY_MARK = re.compile("[°º'′]")
_DECIMAL = re.compile(r"([+-]?)([0-9]+(?:\.[0-9]*)?|\.[0-9]+)([NSEWnsew]?)")
_DEGREES = re.compile(r"([+-]?)([0-9]{1,3})")
_MINUTES = re.compile(r"([0-9]{1,2}(?:\.[0-9]*)?)([NSEWnsew]?)")
_HEMISPHERES = {"lat": ("N", "S"), "lon": ("E", "W")}
_LETTERS = frozenset("NSEW")
MINUTES_PER_DEGREE = 60
LAT_MAX = fix_shape.RANGES["lat"][1]  # degrees: more can only be a longitude's
COORDINATE_FORMS = "-32.0380 115.3325 or 32 02.28S 115 19.95E"


def _coordinates(spec: catalog.CommandKind, args: Sequence[str]) -> list[str]:
    """``args`` with a trailing latitude and longitude rewritten as signed decimal degrees.

    Two values are decimal degrees (``-32.0380 115.3325``, ``32.038S 115.3325E``); four are
    degrees and decimal minutes (``32 02.28S 115 19.95E``, ``-32 02.280 115 19.950``); ``°``
    and ``'`` marks may separate them (``32°02.28'S``). A hemisphere letter follows the value
    (joined or spaced) and replaces its sign. The catalog then checks the ranges as for any number.
    """
    params = spec.params
    if len(params) < 2 or params[-2] is not catalog.LAT or params[-1] is not catalog.LON:
        return list(args)
    lead = len(params) - 2
    tail = " ".join(args[lead:])
    if _ANY_MARK.search(tail):  # rare: most texts give no ° or '
        tail = _MINUTE_MARKS.sub("", _COORDINATE_MARKS.sub(" ", tail))
    values: list[str] = []
    for token in tail.split():
        if values and token.upper() in _LETTERS:  # "02.28' S": the letter belongs to the value
            values[-1] += token
        else:
            values.append(token)
    head = list(args[:lead])
    try:
        _check_arity(spec, values)
    except CatalogError:
        if _numbers(params[:lead], head):
            raise
        return [*head, *values]  # the catalog names what is wrong with the leading values
    if len(values) == 2:
        return [*head, _decimal(values[0], "lat"), _decimal(values[1], "lon")]
    return [*head, _minutes(values[0], values[1], "lat"), _minutes(values[2], values[3], "lon")]


def _numbers(params: Sequence[catalog.Param], tokens: Sequence[str]) -> bool:
    """Whether the values before lat lon are numbers where numbers are due (``#WAYPOINT 1``)."""
    for param, token in zip(params, tokens, strict=False):
        try:
            if param.kind == "int":
                int(token)
            elif param.kind == "float":
                float(token)
        except ValueError:
            return False
    return True


def _hemisphere(token: str) -> str:
    letter = token[-1:].upper()
    return letter if letter in _LETTERS else ""


def _one_in_minutes(values: Sequence[str], letters: str) -> bool:
    """``32 02.28S``: two values that are one coordinate in degrees and minutes, its letter
    one of ``letters`` (a decimal pair never ends with N or S in the lon's place)."""
    degrees, minutes = _DEGREES.fullmatch(values[0]), _MINUTES.fullmatch(values[1])
    return (
        degrees is not None
        and minutes is not None
        and minutes.group(2).upper() in letters
        and float(minutes.group(1)) < MINUTES_PER_DEGREE
    )


def _check_arity(spec: catalog.CommandKind, values: Sequence[str]) -> None:
    """Raise a CatalogError naming what is missing or extra when ``values`` are not one
    latitude and one longitude in the same form (2 decimal values or 4 in degrees and minutes).

    Hemisphere letters tell which coordinate was given: ``32 02.28S`` is a latitude alone
    (issue 16 §15: it was read as lat 32, lon 2.28S, and refused for the letter), ``115 19.95E``
    a longitude alone when its degrees are past any latitude.
    """
    count = len(values)
    if count == 0:
        raise CatalogError("latitude and longitude missing", field="lat")
    if count == 1:
        if _hemisphere(values[0]) in ("E", "W"):
            raise CatalogError("latitude missing", field="lat")
        raise CatalogError("longitude missing", field="lon")
    if count == 2:
        second = _hemisphere(values[1])
        if not second or _hemisphere(values[0]):  # the usual pair: nothing to look into
            return
        if second in "NS" and _one_in_minutes(values, "NS"):
            raise CatalogError("longitude missing", field="lon")
        if _one_in_minutes(values, "EW") and int(values[0].lstrip("+-")) > LAT_MAX:
            raise CatalogError("latitude missing", field="lat")
        return
    if _hemisphere(values[0]) and _hemisphere(values[1]):  # two decimal values, then more
        raise _extra(spec, values[2:])
    if count > 4:
        raise _extra(spec, values[4:])
    if count == 3:
        raise CatalogError(f"3 values for lat lon: give lat lon as {COORDINATE_FORMS}", field="lat")


def _extra(spec: catalog.CommandKind, extra: Sequence[str]) -> CatalogError:
    usage = " ".join(p.name for p in spec.params)
    return CatalogError(f"#{spec.sms_word} takes {usage}; extra: {' '.join(extra)}")


def _signed(name: str, sign: str, hemisphere: str) -> float:
    north, south = _HEMISPHERES[name]
    letter = hemisphere.upper()
    if letter and sign:
        raise CatalogError(f"{name}: give a sign or {north}/{south}, not both", field=name)
    if letter and letter not in (north, south):
        raise CatalogError(f"{name} takes {north} or {south}, not {letter}", field=name)
    return -1.0 if sign == "-" or letter == south else 1.0


def _decimal(token: str, name: str) -> str:
    match = _DECIMAL.fullmatch(token)
    if match is None:
        return token  # not a coordinate form: the catalog says what is wrong with it
    sign, number, hemisphere = match.groups()
    return repr(_signed(name, sign, hemisphere) * float(number))


def _minutes(degrees: str, minutes: str, name: str) -> str:
    d, m = _DEGREES.fullmatch(degrees), _MINUTES.fullmatch(minutes)
    if d is None or m is None:
        raise CatalogError(
            f"{name} must be degrees and minutes as in {COORDINATE_FORMS} "
            f"(got {degrees} {minutes})",
            field=name,
        )
    minute = float(m.group(1))
    if minute >= MINUTES_PER_DEGREE:
        raise CatalogError(f"{name} minutes must be below 60 (got {m.group(1)})", field=name)
    value = int(d.group(2)) + minute / MINUTES_PER_DEGREE
    return repr(_signed(name, d.group(1), m.group(2)) * value)


# -- replies ----------------------------------------------------------------------------------


def answer_error(item: Item) -> Answer:
    return Answer(item.echo, f"ERR {item.error}", error=True)


def answer_command(item: Item, outcome: str, *, error: bool = False) -> Answer:
    """A command's answer (``QUEUED``, ``ERR …``), saying when the SMS gave it several times."""
    note = f"({item.repeats} identical commands in this SMS taken once)" if item.repeats > 1 else ""
    return Answer(item.echo, outcome, error=error, note=note)


def answer_help(item: Item) -> Answer:
    return Answer(item.echo, item.answer)


def compose_reply(answers: Sequence[Answer]) -> str:
    """One SMS of GSM-7 text (at most 160 septets) answering every part of an SMS, in order.

    1. Each answer is spelled in GSM-7 (never a UCS-2 reply), without the characters a
       text-mode modem cannot type (the extension table, Ξ), and, alone, is whole: the echo
       with every value, then the outcome.
    2. An answer too long for its room is shortened at field boundaries: the outcome keeps its
       first words (``...``), then the echo keeps its first values (``+3 more``).
    3. When the answers together are too long, the first ones are kept whole and the rest are
       counted (``+2 more (1 ERR)``). Nothing is ever cut in the middle of a field.
    """
    if not answers:
        return ""
    room = SMS_SEPTETS if len(answers) == 1 else SMS_SEPTETS - NOTE_ROOM
    parts = [_render(a, room) for a in answers]
    whole = SEPARATOR.join(parts)
    if _septets(whole) <= SMS_SEPTETS:
        return whole
    for keep in range(len(parts) - 1, 0, -1):
        rest = answers[keep:]
        errors = sum(1 for a in rest if a.error)
        note = f"+{len(rest)} more" + (f" ({errors} ERR)" if errors else "")
        text = SEPARATOR.join([*parts[:keep], note])
        if septets(text) <= SMS_SEPTETS:
            return text
    return parts[0]  # pragma: no cover - the first part leaves NOTE_ROOM free


# Printable ASCII that is in the GSM-7 basic table, one septet each: most replies are only
# this, and skip the per-character spelling (TS 23.038 §6.2.1; ` [ \\ ] ^ { | } ~ are not).
_PLAIN = re.compile(r"[A-Za-z0-9 !\"#$%&'()*+,\-./:;<=>?@_]*")


# A text-mode modem takes a reply as bytes typed after its "> " prompt, where ESC (before every
# extension-table character) cancels and Ctrl-Z (0x1A, which is Ξ) sends: sms/modem refuses
# both (docs/sms.md, 'The GSM modem'), so replies spell them plainly.
_TYPEABLE = str.maketrans({"[": "(", "]": ")", "{": "(", "}": ")", "~": "-", "|": "/",
                           "\\": "/", "^": "'", "€": "EUR", "\f": " ", "Ξ": "?"})  # fmt: skip


def _fields(text: str) -> list[str]:
    if _PLAIN.fullmatch(text):
        return text.split()
    return to_gsm7(text).translate(_TYPEABLE).split()


def _length(fields: Sequence[str]) -> int:
    return sum(septets(f) for f in fields) + max(len(fields) - 1, 0)


def _septets(text: str) -> int:
    return len(text) if _PLAIN.fullmatch(text) else septets(text)


def _render(answer: Answer, room: int) -> str:
    said = answer.said
    if _PLAIN.fullmatch(answer.echo) and _PLAIN.fullmatch(said):
        text = " ".join([*answer.echo.split(), *said.split()])
        if len(text) <= room:
            return text  # the usual reply: plain and short
    echo, outcome = _fields(answer.echo), _fields(said)
    if _length(echo) + 1 + _length(outcome) <= room:
        return " ".join([*echo, *outcome])
    outcome = _prefix(outcome, room - ECHO_ROOM, lambda _n: "...")
    echo = _prefix(echo, room - _length(outcome) - 1, lambda n: f"+{n} more")
    return " ".join([*echo, *outcome])


def _prefix(fields: list[str], room: int, marker: Callable[[int], str]) -> list[str]:
    """The longest run of leading fields that fits ``room`` with a marker for the rest."""
    if _length(fields) <= room:
        return fields
    used, keep = 0, 0
    for i, f in enumerate(fields):
        cost = septets(f) + (1 if i else 0)
        tail = septets(marker(len(fields) - i - 1)) + 1
        if used + cost + tail > room:
            break
        used, keep = used + cost, i + 1
    return [*fields[:keep], marker(len(fields) - keep)]
