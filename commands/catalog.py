"""The command catalog: every command kind, its parameters, ranges, text form (docs/operating.md).

Pure Python: no ORM, no DRF. The admin form, the REST API and the SMS parser all validate
through :func:`validate` and adapt :class:`CatalogError` into their own error type.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from commands.errors import CatalogError
from edge_client.contract import catalog as shared
from edge_client.contract import fence as fences
from edge_client.contract.catalog import MISSION_ENDS, MISSION_MAX_ITEMS, MISSION_MAX_MAVLINK_ITEMS
from edge_client.contract.geo import distance_m
from edge_client.contract.kinds import MAVLINK, ROVER_MODES, WAVE_GLIDER
from vessels.missions import format_distance

# Wave Glider waypoint table indices, 1-254 (docs/sms.md#the-language).
WG_INDEX_MIN, WG_INDEX_MAX = 1, 254


def _is_number(value: Any) -> bool:
    # bool is an int in Python; "true" is never a latitude.
    return isinstance(value, int | float) and not isinstance(value, bool)


def _is_finite(value: int | float) -> bool:
    # JSON integers have no size limit; one past float's range is no coordinate either.
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


@dataclass(frozen=True)
class Param:
    """One parameter: a name, a converter that validates and normalises, and its text help."""

    name: str
    kind: str  # "float", "int", "choice", "bool", "indices", "items", "fences"
    help: str
    minimum: float | None = None
    maximum: float | None = None
    choices: tuple[str, ...] = ()
    required: bool = True
    default: Any = None

    def clean(self, value: Any) -> Any:
        return _CLEANERS[self.kind](self, value)

    @functools.cached_property
    def _by_upper(self) -> dict[str, str]:
        """Each choice by its upper-case spelling (computed once: SMS parsing is hot)."""
        return {c.upper(): c for c in self.choices}

    def _range(self, number: float) -> None:
        if (self.minimum is not None and number < self.minimum) or (
            self.maximum is not None and number > self.maximum
        ):
            raise CatalogError(
                f"{self.name} must be between {_fmt(self.minimum)} and {_fmt(self.maximum)}"
                f" (got {_fmt(number)})",
                field=self.name,
            )

    def _clean_float(self, value: Any) -> float:
        if type(value) is float and math.isfinite(value):  # the usual case, checked cheaply
            self._range(value)
            return value
        if not _is_number(value) or not _is_finite(value):
            raise CatalogError(f"{self.name} must be a number", field=self.name)
        number = float(value)
        self._range(number)
        return number

    def _clean_int(self, value: Any) -> int:
        if type(value) is int:  # the usual case (bool is not exactly int), checked cheaply
            self._range(value)
            return value
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if not isinstance(value, int) or isinstance(value, bool):
            raise CatalogError(f"{self.name} must be a whole number", field=self.name)
        self._range(value)
        return value

    def _clean_choice(self, value: Any) -> str:
        choice = self._by_upper.get(value.strip().upper()) if isinstance(value, str) else None
        if choice is None:
            raise CatalogError(
                f"{self.name} must be one of {', '.join(self.choices)}", field=self.name
            )
        return choice

    def _clean_bool(self, value: Any) -> bool:
        if not isinstance(value, bool):
            raise CatalogError(f"{self.name} must be true or false", field=self.name)
        return value

    def _clean_indices(self, value: Any) -> list[int]:
        if not isinstance(value, list | tuple) or not value:
            raise CatalogError(f"{self.name} must be a non-empty list of indices", field=self.name)
        return [self._clean_int(v) for v in value]

    def _clean_items(self, value: Any) -> list[dict[str, Any]]:
        if not isinstance(value, list | tuple) or not value:
            raise CatalogError(
                f"{self.name} must be a non-empty list of waypoints", field=self.name
            )
        if len(value) > MISSION_MAX_ITEMS:
            raise CatalogError(
                f"{self.name} has {len(value)} waypoints; at most {MISSION_MAX_ITEMS}",
                field=self.name,
            )
        return [_clean_mission_item(i, item) for i, item in enumerate(value)]

    def _clean_fences(self, value: Any) -> list[dict[str, Any]]:
        # The contract's rules, which the boat checks by too (edge_client.contract.fence).
        try:
            return fences.clean_fences(value, autopilot=True)
        except fences.FenceError as exc:
            raise CatalogError(str(exc), field=self.name) from None


_CLEANERS: dict[str, Callable[[Param, Any], Any]] = {
    "float": Param._clean_float,
    "int": Param._clean_int,
    "choice": Param._clean_choice,
    "bool": Param._clean_bool,
    "indices": Param._clean_indices,
    "items": Param._clean_items,
    "fences": Param._clean_fences,
}


def _fmt(number: float | None) -> str:
    if number is None:
        return "?"
    if not _is_finite(number):
        return "a number out of range"  # a huge JSON integer: float() would overflow
    if abs(number) >= 1e15:
        return f"{float(number):g}"  # 1e+300, not three hundred digits
    return str(int(number)) if float(number).is_integer() else str(number)


def _ranged(name: str, kind: str, help_: str, **options: Any) -> Param:
    """A parameter the boat checks too: its range is the contract's (shared.RANGES)."""
    minimum, maximum = shared.RANGES[name]
    return Param(name, kind, help_, minimum=minimum, maximum=maximum, **options)


LAT = _ranged("lat", "float", "latitude, decimal degrees")
LON = _ranged("lon", "float", "longitude, decimal degrees")
HOLD_S = _ranged("hold_s", "float", "seconds to hold", required=False, default=0.0)
RADIUS_M = _ranged("radius_m", "float", "acceptance radius, metres", required=False, default=None)
SPEED_MPS = _ranged(
    "speed_mps",
    "float",
    "speed from this item on, m/s (ArduPilot DO_CHANGE_SPEED)",
    required=False,
    default=None,
)
_ITEM_SPECS = {p.name: p for p in (LAT, LON, HOLD_S, RADIUS_M, SPEED_MPS)}
MISSION_ITEM_PARAMS = tuple(_ITEM_SPECS[name] for name in shared.MISSION_ITEM_PARAMS)
_MISSION_ITEM_NAMES = frozenset(p.name for p in MISSION_ITEM_PARAMS)
# How a mission ends (MISSION_ENDS), how many items it may hold (MISSION_MAX_ITEMS) and how
# many the autopilot stores (MISSION_MAX_MAVLINK_ITEMS): the contract's, imported above.


def mission_mavlink_item_count(items: Sequence[Mapping[str, Any]], end: str) -> int:
    """How many MAVLink mission items the boat uploads for these items, home included.

    Home (item 0), then per item an optional DO_CHANGE_SPEED before its NAV_WAYPOINT (which
    carries the hold time), then a DO_JUMP to item 1 (``loop``) or a NAV_RETURN_TO_LAUNCH
    (``return_home``). ``edge_client/mission.build_mission`` builds exactly this; the contract
    test pins the two together.
    """
    speeds = sum(1 for item in items if item.get("speed_mps") is not None)
    return 1 + len(items) + speeds + (0 if end == "stop" else 1)


def _clean_mission_item(index: int, item: Any) -> dict[str, Any]:
    if not isinstance(item, Mapping):
        raise CatalogError(f"items[{index}] must be an object with lat and lon", field="items")
    try:
        return _clean_params(MISSION_ITEM_PARAMS, item, _MISSION_ITEM_NAMES)
    except CatalogError as exc:
        raise CatalogError(f"items[{index}]: {exc.message}", field="items") from None


def _clean_params(
    specs: Sequence[Param], params: Mapping[str, Any], known: frozenset[str]
) -> dict[str, Any]:
    """``params`` checked against ``specs`` (whose names are ``known``), defaults filled in."""
    if not params.keys() <= known:
        unknown = sorted(set(params) - known)
        allowed = ", ".join(sorted(known)) or "none"
        raise CatalogError(
            f"unknown parameter {unknown[0]!r} (allowed: {allowed})", field=unknown[0]
        )
    clean: dict[str, Any] = {}
    for spec in specs:
        value = params.get(spec.name)  # absent or None alike
        if value is None:
            if spec.required:
                raise CatalogError(f"{spec.name} is required ({spec.help})", field=spec.name)
            clean[spec.name] = spec.default
            continue
        clean[spec.name] = spec.clean(value)
    return clean


@dataclass(frozen=True)
class CommandKind:
    name: str
    label: str
    vessel_kinds: tuple[str, ...]
    params: tuple[Param, ...] = ()
    # Navigation commands replace each other: only the newest queued one may reach the boat.
    navigation: bool = False
    # The SMS word (without '#'); None when the kind has no text form.
    sms_word: str | None = None

    def param(self, name: str) -> Param:
        return next(p for p in self.params if p.name == name)

    @functools.cached_property
    def param_names(self) -> frozenset[str]:
        return frozenset(p.name for p in self.params)


def _wg_index(name: str, help_: str) -> Param:
    return Param(name, "int", help_, minimum=WG_INDEX_MIN, maximum=WG_INDEX_MAX)


def _boat_kind(
    name: str,
    label: str,
    *params: Param,
    vessel_kinds: tuple[str, ...] = (MAVLINK,),
    sms_word: str | None = None,
) -> CommandKind:
    """A kind a MAVLink boat runs: its parameter names (in order) and whether it navigates are
    the contract's (shared.KIND_PARAMS, shared.NAVIGATION_KINDS), which the boat checks by."""
    if tuple(p.name for p in params) != shared.KIND_PARAMS[name]:
        raise ValueError(f"{name} takes the contract's parameters {shared.KIND_PARAMS[name]}")
    navigation = name in shared.NAVIGATION_KINDS
    return CommandKind(name, label, vessel_kinds, params, navigation, sms_word)


_ON_OFF = ("on", "off")

KINDS: dict[str, CommandKind] = {
    k.name: k
    for k in (
        _boat_kind("move_to", "Move to a point", LAT, LON),
        _boat_kind("hold", "Hold position", vessel_kinds=(MAVLINK, WAVE_GLIDER), sms_word="HOLD"),
        _boat_kind("resume", "Resume mission (AUTO)"),
        _boat_kind("return_home", "Return home (RTL)"),
        _boat_kind(
            "set_mode",
            "Set autopilot mode",
            Param("mode", "choice", "ArduPilot Rover mode", choices=tuple(ROVER_MODES)),
        ),
        _boat_kind("arm", "Arm motors"),
        _boat_kind("disarm", "Disarm motors"),
        _boat_kind(
            "mission",
            "Run a mission",
            _ranged("mission_id", "int", "mission id on the server", required=False),
            Param("items", "items", "waypoints [{lat, lon, hold_s, radius_m}]"),
            Param("loop", "bool", "repeat the mission", required=False, default=False),
            Param(
                "end",
                "choice",
                "stop, loop or return_home after the last item",
                choices=MISSION_ENDS,
                required=False,
                default=None,
            ),
        ),
        _boat_kind(
            "fence",
            "Load the geofence",
            Param(
                "fences", "fences", "the vessel's fences [{id, name, inclusion, polygon|circle}]"
            ),
        ),
        CommandKind(
            "fhead",
            "Fixed heading",
            (WAVE_GLIDER,),
            (Param("bearing", "int", "degrees true, 0-359", minimum=0, maximum=359),),
            navigation=True,
            sms_word="FHEAD",
        ),
        CommandKind(
            "light",
            "Marker light",
            (WAVE_GLIDER,),
            (Param("state", "choice", "ON or OFF", choices=_ON_OFF),),
            sms_word="LIGHT",
        ),
        CommandKind(
            "ir",
            "Infra-red marker light",
            (WAVE_GLIDER,),
            (Param("state", "choice", "ON or OFF", choices=_ON_OFF),),
            sms_word="IR",
        ),
        CommandKind(
            "waypoint",
            "Set a waypoint",
            (WAVE_GLIDER,),
            (_wg_index("index", "waypoint index 1-254"), LAT, LON),
            sms_word="WAYPOINT",
        ),
        CommandKind(
            "holdwp",
            "Hold at a waypoint",
            (WAVE_GLIDER,),
            (_wg_index("index", "waypoint index 1-254"),),
            navigation=True,
            sms_word="HOLDWP",
        ),
        CommandKind(
            "fseq",
            "Follow a waypoint sequence",
            (WAVE_GLIDER,),
            (
                _wg_index("target", "waypoint to visit first"),
                _wg_index("begin", "first waypoint of the loop"),
                _wg_index("end", "last waypoint of the loop"),
            ),
            navigation=True,
            sms_word="FSEQ",
        ),
        CommandKind(
            "rudder",
            "Rudder angle",
            (WAVE_GLIDER,),
            (Param("angle", "int", "degrees, -30 to 30", minimum=-30, maximum=30),),
            navigation=True,
            sms_word="RUDDER",
        ),
        CommandKind(
            "fcourse",
            "Follow a course",
            (WAVE_GLIDER,),
            (
                Param("mode", "choice", "LOOP or HOLD at the end", choices=("LOOP", "HOLD")),
                Param(
                    "indices",
                    "indices",
                    "waypoint indices 1-254",
                    minimum=WG_INDEX_MIN,
                    maximum=WG_INDEX_MAX,
                ),
            ),
            navigation=True,
            sms_word="FCOURSE",
        ),
    )
}

SMS_WORDS: dict[str, CommandKind] = {k.sms_word: k for k in KINDS.values() if k.sms_word}


@dataclass(frozen=True)
class VesselContext:
    """What some checks need to know of the vessel beyond its kind, handed in by the caller
    (the catalog reads no database): its name for messages, its last fix, its move limit."""

    name: str
    position: tuple[float, float] | None  # (lat, lon) of the last fix; None: never reported
    move_to_max_m: float  # how far a move_to may send it from there; 0: no limit
    limit_source: str = ""  # where the limit is set, for the message ("MOVE_TO_MAX_M")


@dataclass(frozen=True)
class ValidCommand:
    kind: str
    params: dict[str, Any]
    navigation: bool


def get_kind(kind: str) -> CommandKind:
    try:
        return KINDS[kind]
    except (KeyError, TypeError):
        raise CatalogError(
            f"unknown command kind {kind!r} (known: {', '.join(KINDS)})", field="kind"
        ) from None


def kinds_for(vessel_kind: str) -> list[CommandKind]:
    return [k for k in KINDS.values() if vessel_kind in k.vessel_kinds]


def validate(
    kind: str,
    params: Any,
    *,
    vessel_kind: str | None = None,
    vessel: VesselContext | None = None,
) -> ValidCommand:
    """Validate a command for a vessel kind; return normalised params or raise CatalogError.

    1. The kind must exist and (when given) suit the vessel kind.
    2. ``params`` must be an object whose keys are all known parameters.
    3. Each parameter is type-checked and range-checked, defaults filled in.
    4. With ``vessel`` given, a move_to must stay within its limit of the last fix.
    """
    spec = get_kind(kind)
    if vessel_kind is not None and vessel_kind not in spec.vessel_kinds:
        raise CatalogError(
            f"{kind} is not available for {vessel_kind} vessels "
            f"(only {', '.join(spec.vessel_kinds)})",
            field="kind",
        )
    if params is None:
        params = {}
    # dict first: the Mapping ABC check alone costs as much as cleaning a parameter.
    if not isinstance(params, dict) and not isinstance(params, Mapping):
        raise CatalogError("params must be an object", field="params")
    clean = _clean_params(spec.params, params, spec.param_names)
    if spec.name == "mission":
        clean = _mission_end(clean)
        _mission_fits(clean)
    elif spec.name == "move_to" and vessel is not None:
        _move_to_in_reach(clean, vessel)
    return ValidCommand(kind=spec.name, params=clean, navigation=spec.navigation)


def _move_to_in_reach(params: Mapping[str, Any], vessel: VesselContext) -> None:
    """A move_to goes no farther than the vessel's limit from its last fix (issue 16: a map
    click 733 km inland, Perth → London through the API, were queued). Without a last fix
    the distance cannot be measured, so it is refused unless the limit is off (0)."""
    limit = vessel.move_to_max_m
    if limit <= 0:
        return
    where = f" ({vessel.limit_source})" if vessel.limit_source else ""
    if vessel.position is None:
        raise CatalogError(
            f"{vessel.name} has not reported a fix yet, so how far the move_to target is cannot "
            f"be checked; the limit is {format_distance(limit)}{where}"
        )
    metres = distance_m(*vessel.position, params["lat"], params["lon"])
    if metres > limit:
        raise CatalogError(
            f"move_to target is {format_distance(metres)} from {vessel.name}'s last fix; "
            f"the limit is {format_distance(limit)}{where}"
        )


def _mission_end(params: dict[str, Any]) -> dict[str, Any]:
    """Fill in ``end`` from the older ``loop`` flag and keep the two in step.

    Clients written before ``end`` send only ``loop``; boats read ``end``. Either may be given;
    both must agree.
    """
    end = params["end"]
    if end is None:
        end = "loop" if params["loop"] else "stop"
    elif params["loop"] and end != "loop":
        raise CatalogError(f"loop is true but end is {end!r}", field="end")
    return {**params, "end": end, "loop": end == "loop"}


def _mission_fits(params: Mapping[str, Any]) -> None:
    """The autopilot must be able to store the mission it is sent (see the count above)."""
    count = mission_mavlink_item_count(params["items"], params["end"])
    if count > MISSION_MAX_MAVLINK_ITEMS:
        raise CatalogError(
            f"the mission needs {count} autopilot items (home, waypoints, speed changes and "
            f"its end); the autopilot stores at most {MISSION_MAX_MAVLINK_ITEMS}",
            field="items",
        )


def split_text(text: str) -> tuple[str, list[str]]:
    """One text command's word (upper case, without ``#``) and its values, split on spaces."""
    tokens = text.split()  # split() drops the surrounding whitespace strip() would
    if not tokens or not tokens[0].startswith("#"):
        raise CatalogError("a command starts with # (for example #FHEAD 230)")
    return tokens[0][1:].upper(), tokens[1:]


def sms_kind(word: str) -> CommandKind:
    """The kind whose whole SMS word is ``word`` (``HOLDWP`` is never ``HOLD``)."""
    spec = SMS_WORDS.get(word)
    if spec is None:
        raise CatalogError(f"unknown command #{word}", field="kind")
    return spec


def parse_text(text: str, *, vessel_kind: str = WAVE_GLIDER) -> ValidCommand:
    """Parse the SMS text form (``#FHEAD 230``, ``#FCOURSE HOLD 3 4 1``) into a valid command.

    Every token must be used: ``#FSEQ 1 1`` is refused rather than sent short (docs/level2.md).
    """
    word, args = split_text(text)
    return parse_words(word, args, vessel_kind=vessel_kind)


def parse_words(word: str, args: Sequence[str], *, vessel_kind: str = WAVE_GLIDER) -> ValidCommand:
    """The text form already split into its word and values (see :func:`split_text`)."""
    spec = sms_kind(word)
    params: dict[str, Any] = {}
    used = 0
    for param in spec.params:
        if param.kind == "indices":
            params[param.name] = [_token_number(param, a) for a in args[used:]]
            used = len(args)
            break
        if used == len(args):
            raise CatalogError(f"#{word} needs {param.name} ({param.help})", field=param.name)
        token = args[used]
        used += 1
        params[param.name] = token if param.kind == "choice" else _token_number(param, token)
    if used < len(args):
        extra = " ".join(args[used:])
        raise CatalogError(f"#{word} takes {len(spec.params)} value(s); extra: {extra}")
    return validate(spec.name, params, vessel_kind=vessel_kind)


def _token_number(param: Param, token: str) -> int | float:
    try:
        return int(token) if param.kind in {"int", "indices"} else float(token)
    except ValueError:
        raise CatalogError(
            f"{param.name} must be a number (got {token!r})", field=param.name
        ) from None


def to_text(kind: str, params: Mapping[str, Any]) -> str:
    """The SMS text form of a valid command, e.g. ``#FSEQ 1 1 4``."""
    spec = get_kind(kind)
    if spec.sms_word is None:
        raise CatalogError(f"{kind} has no text form", field="kind")
    parts = [f"#{spec.sms_word}"]
    for param in spec.params:
        value = params[param.name]
        if param.kind == "indices":
            parts.extend(str(v) for v in value)
        elif param.kind == "choice":
            parts.append(str(value).upper())
        elif param.kind == "float":
            parts.append(f"{value:.4f}")
        else:
            parts.append(str(value))
    return " ".join(parts)
