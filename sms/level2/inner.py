"""The inner ("Level 1") command table: command word → command value → parameter layout.

References (§ as in docs/level2.md#section-numbers-in-the-code): §11.1 the command packet and
the public command values; §13–§14 the open questions, named settings in the data file; the
Wave Glider words and ranges of docs/sms.md#the-language; the field trials (``#HOLDWP 1`` sent
as ``#HOLD``, ``#FSEQ 1 1 4`` losing its last parameter), which the loader makes impossible by
refusing any entry that does not encode every declared parameter.

The table is data (``inner_commands.toml``) so that someone holding LRI's handbook can correct it
without touching code. It holds only the wire layout: each word must be a Wave Glider kind of the
command catalog (``commands/catalog.py``), which gives the parameters' ranges, so
the SMS parser, the admin and the encoder cannot disagree on them. Pure: the catalog is pure
Python too (sms sits above commands; neither imports Django here), and the only file read is the
table, through ``importlib.resources``.
"""

from __future__ import annotations

import struct
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

from commands import catalog

from .bodies import PARAMS_SIZE, CommandPacket, degrees_to_l2
from .errors import CommandRefused, TableError

TABLE_RESOURCE = "inner_commands.toml"
SOURCED = "sourced"
PROVISIONAL = "provisional"
UNKNOWN = "unknown"  # a choice whose command value nobody has published
_FIELD_FORMATS = {"u8": "<B", "i8": "<b", "u16": "<H", "i16": "<h"}
_FIELD_RANGES = {"u8": (0, 0xFF), "i8": (-0x80, 0x7F), "u16": (0, 0xFFFF), "i16": (-0x8000, 0x7FFF)}
# Table parameter type → the catalog parameter kind it carries.
_PARAM_TYPES = {
    "int": "int",
    "choice": "choice",
    "lat": "float",
    "lon": "float",
    "int_list": "indices",
}
# Rules are the catalog's; an entry giving its own is refused rather than silently ignored.
_CATALOG_KEYS = {"min", "max", "min_count"}


@dataclass(frozen=True, slots=True)
class InnerSettings:
    """The open questions (§13–§14, docs/level2.md) as named settings."""

    inner_size_includes_crc: bool = False  # §13: PC 16 (no) vs Goby 18 (yes); page default: no
    wgms_id: int = 0  # §14 q2: 0 (PC) or 0xFFFFFFFF (Goby)
    inner_crc: bool = True  # §11.1: both sources append it


@dataclass(frozen=True, slots=True)
class ParamSpec:
    name: str
    type: str
    min: float | None = None  # from the catalog
    max: float | None = None  # from the catalog
    choices: Mapping[str, int | None] = field(default_factory=dict)
    min_count: int = 1  # the catalog's lists of indices are never empty
    max_count: int = PARAMS_SIZE


@dataclass(frozen=True, slots=True)
class FieldSpec:
    at: int
    type: str
    source: str
    abs: bool = False

    @property
    def size(self) -> int:
        return 0 if self.type == "u8list" else struct.calcsize(_FIELD_FORMATS[self.type])


@dataclass(frozen=True, slots=True)
class CommandSpec:
    """One table entry. ``value`` xor ``value_from`` (a choice) xor ``value_by_sign``."""

    word: str
    status: str
    enabled: bool
    source: str
    params: tuple[ParamSpec, ...]
    fields: tuple[FieldSpec, ...] = ()
    value: int | None = None
    value_from: str | None = None
    value_by_sign: Mapping[str, Any] | None = None
    fixed: bytes = bytes(PARAMS_SIZE)

    @property
    def usable(self) -> bool:
        return self.status == SOURCED or self.enabled


@dataclass(frozen=True, slots=True)
class InnerCommand:
    """A command the table accepted: its word, typed parameters and the packet to send."""

    word: str
    params: Mapping[str, Any]
    packet: CommandPacket
    provisional: bool

    @property
    def text(self) -> str:
        """The command as an operator would type it, every parameter included."""
        parts = [self.word]
        for value in self.params.values():
            if isinstance(value, list | tuple):
                parts.extend(str(v) for v in value)
            else:
                parts.append(str(value))
        return " ".join(parts)


class InnerCommandTable:
    """The loaded and checked table; :meth:`encode` turns a command into an inner packet."""

    def __init__(self, settings: InnerSettings, commands: Mapping[str, CommandSpec]) -> None:
        self.settings = settings
        self.commands = dict(commands)
        # Usable entries that encode every value the catalog accepts (decided once, per entry
        # object: an entry replaced later is checked in full).
        self._encodes_all_valid = {
            word: spec
            for word, spec in self.commands.items()
            if spec.usable and _encodes_every_valid(spec)
        }

    # -- loading ------------------------------------------------------------------------------

    @classmethod
    def load(cls, path: str | Path | None = None) -> InnerCommandTable:
        """Load the shipped table, or ``path``; raises TableError if it is inconsistent."""
        if path is None:
            text = resources.files(__package__).joinpath(TABLE_RESOURCE).read_text("utf-8")
        else:
            text = Path(path).read_text("utf-8")
        return cls.from_toml(text)

    @classmethod
    def from_toml(cls, text: str) -> InnerCommandTable:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise TableError(f"inner command table is not valid TOML: {exc}") from exc
        return cls.from_dict(data)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> InnerCommandTable:
        raw_settings = dict(data.get("settings", {}))
        try:
            settings = InnerSettings(**raw_settings)
        except TypeError as exc:
            raise TableError(f"unknown setting in [settings]: {exc}") from exc
        if not 0 <= settings.wgms_id <= 0xFFFFFFFF:
            raise TableError("wgms_id must be a u32")
        commands = {
            word.lower(): _load_entry(word.lower(), entry)
            for word, entry in data.get("commands", {}).items()
        }
        return cls(settings, commands)

    # -- use ----------------------------------------------------------------------------------

    def parse(self, text: str) -> InnerCommand:
        """Encode a command typed as text: ``"fhead 230"``, ``"#WAYPOINT 1 -32.03 115.3"``."""
        words = text.strip().lstrip("#").split()
        if not words:
            raise CommandRefused("", "empty command")
        return self.encode(words[0], words[1:])

    def encode(self, word: str, args: Sequence[Any] | Mapping[str, Any] = ()) -> InnerCommand:
        """Check and encode one command (raises CommandRefused with a readable reason).

        1. The word must be in the table, and sourced or provisional-and-enabled.
        2. The arguments (positional, or by name) are converted and range-checked.
        3. The command value is chosen (fixed, by a choice, or by the sign of a parameter).
        4. Every parameter is placed into the 5 parameter bytes or lat/lon (§11.1).
        """
        key, spec, values, value, params, lat, lon = self._encode(word, args)
        packet = CommandPacket(
            value,
            bytes(params),
            lat,
            lon,
            self.settings.wgms_id,
            self.settings.inner_size_includes_crc,
            self.settings.inner_crc,
        )
        return InnerCommand(key, values, packet, spec.status == PROVISIONAL)

    def check(self, word: str, args: Sequence[Any] | Mapping[str, Any] = ()) -> None:
        """Raise CommandRefused exactly when :meth:`encode` would, building no packet (the
        SMS parser asks this of every command it reads)."""
        self._encode(word, args)

    def check_valid(self, word: str, params: Mapping[str, Any]) -> None:
        """:meth:`check` for params the command catalog has validated (``catalog.validate``).

        An entry whose every parameter fits its field over the catalog's whole range (see
        :func:`_encodes_every_valid`) cannot refuse such params, so only its usability is
        looked at; any other is checked in full.
        """
        spec = self.commands.get(word.lower().lstrip("#"))
        if spec is None or self._encodes_all_valid.get(spec.word) is not spec:
            self._encode(word, params)

    def _encode(
        self, word: str, args: Sequence[Any] | Mapping[str, Any]
    ) -> tuple[str, CommandSpec, dict[str, Any], int, bytearray, int, int]:
        key = word.lower().lstrip("#")
        spec = self.commands.get(key)
        if spec is None:
            known = ", ".join(sorted(self.commands))
            raise CommandRefused(key, f"not in the inner command table (known: {known})")
        if not spec.usable:
            raise CommandRefused(
                key,
                f"provisional entry not enabled; source: {spec.source}. Set enabled = true in "
                f"{TABLE_RESOURCE} only after testing against hardware",
            )
        values = _bind(spec, args)
        value = _command_value(spec, values)
        params = bytearray(spec.fixed)
        lat = lon = 0
        for p in spec.params:
            if p.type == "lat":
                lat = degrees_to_l2(values[p.name], limit=_limit(p))
            elif p.type == "lon":
                lon = degrees_to_l2(values[p.name], limit=_limit(p))
        for f in spec.fields:
            _place(spec, f, values[f.source], params)
        return key, spec, values, value, params, lat, lon


def _load_entry(word: str, entry: Mapping[str, Any]) -> CommandSpec:
    """Build and check one entry; every inconsistency is a TableError naming the word.

    1. Read the entry's wire layout (status, source, params, fields, fixed bytes, value).
    2. Check its structure (:func:`_check_entry`).
    3. Match it to the catalog's command of the same name and take the ranges from there.
    """

    def fail(reason: str) -> TableError:
        return TableError(f"inner command table, [commands.{word}]: {reason}")

    spec = _read_entry(word, entry, fail)
    _check_entry(spec, fail)
    return _with_catalog_rules(spec, fail)


def _read_entry(word: str, entry: Mapping[str, Any], fail: Any) -> CommandSpec:
    status = entry.get("status")
    if status not in (SOURCED, PROVISIONAL):
        raise fail(f'status must be "{SOURCED}" or "{PROVISIONAL}", not {status!r}')
    if not entry.get("source"):
        raise fail("every entry needs a source")
    try:
        params = tuple(_param(p) for p in entry.get("params", []))
        fields_ = tuple(
            FieldSpec(f["at"], f["type"], f["from"], bool(f.get("abs", False)))
            for f in entry.get("fields", [])
        )
        fixed = bytes.fromhex(entry.get("fixed", "00" * PARAMS_SIZE))
    except (KeyError, TypeError, ValueError) as exc:
        raise fail(f"malformed params/fields/fixed: {exc}") from exc
    return CommandSpec(
        word=word,
        status=status,
        enabled=bool(entry.get("enabled", status == SOURCED)),
        source=entry["source"],
        params=params,
        fields=fields_,
        value=entry.get("value"),
        value_from=entry.get("value_from"),
        value_by_sign=entry.get("value_by_sign"),
        fixed=fixed,
    )


def _param(raw: Mapping[str, Any]) -> ParamSpec:
    if raw["type"] not in _PARAM_TYPES:
        raise ValueError(f"unknown parameter type {raw['type']!r}")
    ruled = sorted(_CATALOG_KEYS & set(raw))
    if ruled:
        raise ValueError(
            f"{raw['name']!r} gives {ruled}: ranges come from the command catalog "
            "(commands/catalog.py), the table holds only the wire layout"
        )
    # A choice value that is not an integer ("unknown") is a command value nobody published.
    choices = {
        str(k).lower(): v if isinstance(v, int) else None for k, v in raw.get("choices", {}).items()
    }
    return ParamSpec(
        raw["name"],
        raw["type"],
        choices=choices,
        max_count=raw.get("max_count", PARAMS_SIZE),
    )


def _check_entry(spec: CommandSpec, fail: Any) -> None:
    """Structural rules: one value source, every parameter encoded, fields inside 5 bytes."""
    _check_value_source(spec, fail)
    if len(spec.fixed) != PARAMS_SIZE:
        raise fail(f"fixed must be {PARAMS_SIZE} bytes")
    encoded = _check_fields(spec, fail) | _value_params(spec)
    encoded |= {p.name for p in spec.params if p.type in ("lat", "lon")}
    missing = {p.name for p in spec.params} - encoded
    if missing:
        # The field trials' #FSEQ failure: a parameter that is accepted but never sent.
        raise fail(f"parameters {sorted(missing)} are declared but never encoded")


def _check_value_source(spec: CommandSpec, fail: Any) -> None:
    """Exactly one way to the command value at most; a known one if the entry is to be sent."""
    ways = [spec.value is not None, spec.value_from is not None, spec.value_by_sign is not None]
    if sum(ways) > 1:
        raise fail("give only one of value, value_from, value_by_sign")
    if spec.enabled and spec.status == PROVISIONAL and not _value_known(spec):
        raise fail("cannot be enabled: its command value is unknown")
    if spec.value_from and spec.value_from not in {p.name for p in spec.params if p.choices}:
        raise fail("value_from must name a choice parameter")


def _check_fields(spec: CommandSpec, fail: Any) -> set[str]:
    """Each field has a known type, takes a declared parameter and its own bytes of the 5.

    Returns the names of the parameters the fields encode.
    """
    names = {p.name for p in spec.params}
    occupied: set[int] = set()
    for f in spec.fields:
        if f.type != "u8list" and f.type not in _FIELD_FORMATS:
            raise fail(f"field type {f.type!r} unknown")
        if f.source not in names:
            raise fail(f"field takes {f.source!r}, which is not a parameter")
        end = PARAMS_SIZE if f.type == "u8list" else f.at + f.size
        span = set(range(f.at, end))
        if f.at < 0 or end > PARAMS_SIZE or span & occupied:
            raise fail(f"field for {f.source!r} overlaps another or leaves the 5 parameter bytes")
        occupied |= span
    return {f.source for f in spec.fields}


def _value_params(spec: CommandSpec) -> set[str]:
    """The parameters that choose the command value (and so are encoded by it)."""
    used = {spec.value_from} if spec.value_from else set()
    if spec.value_by_sign:
        used.add(spec.value_by_sign.get("from", ""))
    return used


def _with_catalog_rules(spec: CommandSpec, fail: Any) -> CommandSpec:
    """The entry with each parameter's range from the catalog's Wave Glider command.

    The word must be a catalog kind for Wave Gliders, with the same parameters in the same
    order, of a matching type and, for choices, the same choice names.
    """
    try:
        kind = catalog.get_kind(spec.word)
    except catalog.CatalogError:
        raise fail("not a command of the catalog (commands/catalog.py)") from None
    if catalog.WAVE_GLIDER not in kind.vessel_kinds:
        raise fail("the catalog does not offer it to Wave Gliders")
    if [p.name for p in spec.params] != [p.name for p in kind.params]:
        raise fail(f"parameters must be the catalog's: {[p.name for p in kind.params]}")
    return replace(spec, params=tuple(_ruled(p, kind.param(p.name), fail) for p in spec.params))


def _ruled(p: ParamSpec, rule: catalog.Param, fail: Any) -> ParamSpec:
    if _PARAM_TYPES[p.type] != rule.kind:
        raise fail(f"{p.name} is {rule.kind!r} in the catalog but {p.type!r} in the table")
    if p.choices and set(p.choices) != {c.lower() for c in rule.choices}:
        raise fail(f"{p.name} choices must be the catalog's: {'/'.join(rule.choices)}")
    if p.type in ("lat", "lon") and (rule.maximum is None or rule.minimum != -rule.maximum):
        raise fail(f"{p.name}: a coordinate needs a symmetric range in the catalog")
    return replace(p, min=rule.minimum, max=rule.maximum)


def _value_known(spec: CommandSpec) -> bool:
    if spec.value is not None:
        return True
    if spec.value_from:
        choice = next((p for p in spec.params if p.name == spec.value_from), None)
        return bool(choice and choice.choices) and all(
            v is not None for v in choice.choices.values()
        )
    if spec.value_by_sign:
        signs = ("positive", "negative", "zero")
        return all(isinstance(spec.value_by_sign.get(k), int) for k in signs)
    return False


def _encodes_every_valid(spec: CommandSpec) -> bool:
    """True when :meth:`InnerCommandTable.encode` accepts every value the catalog accepts.

    After the catalog's checks only the wire can refuse: a value outside its field's format
    (a bearing of 359 in a u8), a list longer than its bytes (the catalog does not bound
    lists), a command value nobody published. Integer ranges are intervals, so their ends
    (and 0 for ``abs``) decide; choices are few, so each one does.
    """
    if not _value_known(spec) or any(p.type == "int_list" for p in spec.params):
        return False
    by_name = {p.name: p for p in spec.params}
    for f in spec.fields:
        p = by_name[f.source]
        if f.type not in _FIELD_RANGES:
            return False
        if p.type == "choice":
            values = list(p.choices.values())
        elif p.type == "int" and p.min is not None and p.max is not None:
            values = [p.min, p.max, *([0] if p.min < 0 < p.max else [])]
        else:
            return False
        if any(v is None for v in values):
            return False
        low, high = _FIELD_RANGES[f.type]
        if not all(low <= (abs(v) if f.abs else v) <= high for v in values):
            return False
    return True


def _bind(spec: CommandSpec, args: Sequence[Any] | Mapping[str, Any]) -> dict[str, Any]:
    """Match arguments to parameters, converting text and checking ranges."""
    word = spec.word
    # dict first: the ABC check alone costs as much as binding a parameter.
    if isinstance(args, dict) or isinstance(args, Mapping):
        extra = set(args) - {p.name for p in spec.params}
        if extra:
            raise CommandRefused(word, f"unexpected parameters {sorted(extra)}")
        try:
            items = [(p, args[p.name]) for p in spec.params]
        except KeyError as exc:
            raise CommandRefused(word, f"missing parameter {exc.args[0]!r}") from None
    else:
        positional = list(args)
        items = []
        consumed = 0
        for i, p in enumerate(spec.params):
            if p.type == "int_list":  # a list takes every remaining argument
                items.append((p, positional[i:]))
                consumed = len(positional)
                break
            if i >= len(positional):
                raise CommandRefused(word, f"missing parameter {p.name!r} ({_usage(spec)})")
            items.append((p, positional[i]))
            consumed = i + 1
        if len(positional) > consumed:
            raise CommandRefused(word, f"too many parameters ({_usage(spec)})")
    return {p.name: _convert(word, p, raw) for p, raw in items}


def _usage(spec: CommandSpec) -> str:
    return "usage: " + " ".join([spec.word, *(f"<{p.name}>" for p in spec.params)])


def _convert(word: str, p: ParamSpec, raw: Any) -> Any:
    try:
        if p.type == "int":
            return _int_in_range(word, p, raw)
        if p.type == "choice":
            key = str(raw).lower()
            if key not in p.choices:
                raise CommandRefused(word, f"{p.name} must be one of {'/'.join(p.choices)}")
            return key
        if p.type in ("lat", "lon"):
            value = float(raw)
            if not -_limit(p) <= value <= _limit(p):
                raise CommandRefused(word, f"{p.name} must be within ±{_limit(p):g} degrees")
            return value
        # int_list
        items = [raw] if isinstance(raw, str | int) else list(raw)
        if not p.min_count <= len(items) <= p.max_count:
            raise CommandRefused(
                word, f"{p.name} takes {p.min_count}–{p.max_count} values, got {len(items)}"
            )
        return [_int_in_range(word, p, item) for item in items]
    except (TypeError, ValueError) as exc:
        if isinstance(exc, CommandRefused):
            raise
        raise CommandRefused(word, f"{p.name}: {raw!r} is not a valid {p.type}") from None


def _int_in_range(word: str, p: ParamSpec, raw: Any) -> int:
    if isinstance(raw, bool) or isinstance(raw, float):
        raise ValueError("not an integer")
    value = int(raw)
    if (p.min is not None and value < p.min) or (p.max is not None and value > p.max):
        raise CommandRefused(word, f"{p.name} must be {_fmt(p.min)}–{_fmt(p.max)}, got {value}")
    return value


def _fmt(limit: float | None) -> str:
    return "…" if limit is None else f"{limit:g}"


def _limit(p: ParamSpec) -> float:
    """The catalog's range of a latitude or longitude, ±90 or ±180 (symmetric: see _ruled)."""
    return float(p.max or 0.0)


def _command_value(spec: CommandSpec, values: Mapping[str, Any]) -> int:
    if spec.value is not None:
        return spec.value
    if spec.value_from:
        choice = next(p for p in spec.params if p.name == spec.value_from)
        value = choice.choices[values[spec.value_from]]
        if value is None:  # pragma: no cover - the loader refuses enabling unknown values
            raise CommandRefused(spec.word, "command value unknown")
        return value
    if spec.value_by_sign:
        amount = values[spec.value_by_sign["from"]]
        key = "positive" if amount > 0 else "negative" if amount < 0 else "zero"
        return int(spec.value_by_sign[key])
    raise CommandRefused(spec.word, "the table gives no command value")


def _place(spec: CommandSpec, f: FieldSpec, value: Any, params: bytearray) -> None:
    if f.type == "u8list":
        room = PARAMS_SIZE - f.at
        if len(value) > room:
            raise CommandRefused(spec.word, f"{f.source}: at most {room} values fit")
        for i, item in enumerate(value):
            if not 0 <= item <= 0xFF:
                raise CommandRefused(spec.word, f"{f.source}: {item} does not fit a byte")
            params[f.at + i] = item
        return
    param = next(p for p in spec.params if p.name == f.source)
    number = param.choices[value] if param.type == "choice" else value
    if f.abs:
        number = abs(number)
    try:
        struct.pack_into(_FIELD_FORMATS[f.type], params, f.at, number)
    except struct.error as exc:
        raise CommandRefused(spec.word, f"{f.source}={value} does not fit a {f.type}") from exc
