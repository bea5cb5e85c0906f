"""Configuration: one TOML file (``/etc/shoreside/edge.toml``) plus command-line overrides.

Parsed once into frozen dataclasses. Anything wrong (unknown key, wrong type, out of range,
missing server URL) raises :class:`ConfigError`, a ``ValueError`` whose message names the file,
the table and the key, so ``systemctl status`` shows what to fix.

Example file (every table and key is optional except where a value has no default)::

    [server]
    url = "https://shore.example.org"
    key_file = "/etc/shoreside/edge.key"   # or key = "..."; or env SHORESIDE_EDGE_KEY

    [mavlink]
    connection = "/dev/ttyAMA0"            # or "udpin:0.0.0.0:14550", "tcp:127.0.0.1:5760"
    baud = 57600

    [telemetry]
    period_s = 10
    encoding = "json"                      # or "compact": a few bytes a fix (docs/links.md)
    channels = [{name = "water_temp_c", step = 0.01}]   # compact readings; the shore's table

    [commands]
    poll_period_s = 10

    [outbox]
    path = "/var/lib/shoreside-edge/outbox.sqlite3"
    max_fixes = 100000

    [transport]
    kind = "http"                           # or "modem"

    [sbd]                                   # an Iridium SBD modem: the fallback link
    port = "/dev/ttyUSB1"                   # a pyserial URL or device; absent: no SBD
    baudrate = 19200
    fallback_after_s = 300                  # HTTP failing this long: fixes go by SBD
    period_s = 900                          # one SBD message this often while it does
    mailbox_check = true                    # answer ring alerts, fetch waiting MT messages

    [readings.water_temp_c]                 # extra sensor values sent in a fix's "readings"
    message = "SCALED_PRESSURE2"
    field = "temperature"
    scale = 0.01
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from edge_client.contract.compact import Channel, CompactError, channels_from

KEY_ENV = "SHORESIDE_EDGE_KEY"
TELEMETRY_ENCODINGS = ("json", "compact")


class ConfigError(ValueError):
    """The configuration cannot be used; the message says where and why."""


@dataclass(frozen=True)
class ServerConfig:
    url: str = ""
    key: str = field(default="", repr=False)  # a secret: never in a log line or a traceback
    key_file: str = ""


@dataclass(frozen=True)
class MavlinkConfig:
    connection: str = "/dev/ttyAMA0"
    baud: int = 57600
    # Our own MAVLink identity: a companion computer (MAV_COMP_ID_ONBOARD_COMPUTER = 191).
    source_system: int = 1
    source_component: int = 191
    # Rate asked of the autopilot for GLOBAL_POSITION_INT and friends
    # (MAV_CMD_SET_MESSAGE_INTERVAL).
    stream_rate_hz: float = 4.0
    # No HEARTBEAT for this long and the autopilot counts as silent.
    silent_after_s: float = 5.0


@dataclass(frozen=True)
class TelemetryConfig:
    period_s: float = 10.0
    batch_size: int = 50
    # "compact": fixes go as application/vnd.shoreside.fixes, a few bytes each
    # (edge_client/contract/compact.py), with readings by the channel table below, which the
    # shore must list alike for the vessel; "json": as JSON.
    encoding: str = "json"
    channels: tuple[Channel, ...] = ()


@dataclass(frozen=True)
class CommandsConfig:
    # Poll for commands and send what the outbox holds (fixes in batches) this often: one
    # uplink cadence keeps the modem/3G link idle in between.
    poll_period_s: float = 10.0
    # Ask for the command list in the answer to each telemetry post (X-Commands-ETag): a
    # round that sent fixes then needs no poll. Off: poll every round, as before.
    exchange: bool = True
    arm_before_move: bool = True
    arm_timeout_s: float = 60.0
    acceptance_radius_m: float = 10.0
    # After boot the autopilot may not be heard yet, and refuses modes that need a position
    # (GUIDED, AUTO, RTL, ...) until its EKF has one: a command waits this long for each,
    # retrying, before it fails.
    ready_timeout_s: float = 120.0


@dataclass(frozen=True)
class OutboxConfig:
    path: str = "/var/lib/shoreside-edge/outbox.sqlite3"
    max_fixes: int = 100_000
    # Fixes are committed (fsynced) in groups: at the latest once this many wait, and before
    # each uplink round reads them. A power cut loses at most the fixes not committed yet.
    commit_every: int = 10


@dataclass(frozen=True)
class ModemConfig:
    port: str = "/dev/ttyUSB0"
    baud: int = 115200
    trigger: str = "don"
    connect_delay_s: float = 1.0


@dataclass(frozen=True)
class TransportConfig:
    kind: str = "http"
    timeout_s: float = 20.0
    retries: int = 2
    backoff_s: float = 1.0
    ca_bundle: str = ""
    modem: ModemConfig = field(default_factory=ModemConfig)


@dataclass(frozen=True)
class SbdLinkConfig:
    """[sbd]: the boat's Iridium SBD modem, the link used when HTTP fails (sbd_fallback.py)."""

    port: str = ""  # a pyserial URL or device; empty: the boat has no SBD modem
    baudrate: int = 19200
    # HTTP must have been failing this long before fixes go by SBD (each message costs).
    fallback_after_s: float = 300.0
    # One SBD session this often while HTTP keeps failing.
    period_s: float = 900.0
    # Answer ring alerts at once (the shore sent a command) and fetch the MT messages still
    # waiting at the gateway; off: sessions only send.
    mailbox_check: bool = True


@dataclass(frozen=True)
class ReadingSource:
    """One extra reading: ``<message>.<field> * scale`` from the autopilot, sent as ``name``."""

    name: str
    message: str
    field: str
    scale: float = 1.0


@dataclass(frozen=True)
class Config:
    server: ServerConfig = field(default_factory=ServerConfig)
    mavlink: MavlinkConfig = field(default_factory=MavlinkConfig)
    telemetry: TelemetryConfig = field(default_factory=TelemetryConfig)
    commands: CommandsConfig = field(default_factory=CommandsConfig)
    outbox: OutboxConfig = field(default_factory=OutboxConfig)
    transport: TransportConfig = field(default_factory=TransportConfig)
    sbd: SbdLinkConfig = field(default_factory=SbdLinkConfig)
    readings: tuple[ReadingSource, ...] = ()
    log_level: str = "INFO"


# Command-line flag → (table, key). Flags override the file and make it optional.
OVERRIDES: dict[str, tuple[str, str]] = {
    "server": ("server", "url"),
    "key": ("server", "key"),
    "key_file": ("server", "key_file"),
    "mavlink": ("mavlink", "connection"),
    "baud": ("mavlink", "baud"),
    "telemetry_period": ("telemetry", "period_s"),
    "poll_period": ("commands", "poll_period_s"),
    "outbox": ("outbox", "path"),
    "transport": ("transport", "kind"),
    "modem_port": ("modem", "port"),
    "log_level": ("", "log_level"),
}

_TRANSPORT_KINDS = ("http", "modem")
_LOG_LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR")


def load_config(
    path: str | os.PathLike[str] | None, overrides: dict[str, Any] | None = None
) -> Config:
    """Read ``path`` (if given), apply ``overrides`` (flag name → value, None = not given), check.

    1. Parse the TOML file; a syntax error names the line.
    2. Apply the overrides on top.
    3. Build each table's dataclass, refusing unknown keys and wrong types.
    4. Resolve the vessel key (flag/file value, ``key_file``, or ``$SHORESIDE_EDGE_KEY``).
    5. Check cross-field rules (server URL present and http(s), periods positive, ...).
    """
    source = str(path) if path else "command line"
    raw = _read_toml(path, source) if path else {}
    _apply_overrides(raw, overrides or {}, source)
    config = _build_config(raw, source)
    config = replace(config, server=replace(config.server, key=_resolve_key(config.server, source)))
    _check(config, source)
    return config


# --- 1. reading ------------------------------------------------------------------------------


def _read_toml(path: str | os.PathLike[str], source: str) -> dict[str, Any]:
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{source}: no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML: {exc}") from None


# --- 2. overrides ----------------------------------------------------------------------------


def _apply_overrides(raw: dict[str, Any], overrides: dict[str, Any], source: str) -> None:
    """Write each given flag's value into ``raw`` at its (table, key) from :data:`OVERRIDES`.

    ``--key-file`` overrides a ``key`` in the file too (a key given there would win otherwise).
    """
    if overrides.get("key_file") is not None and overrides.get("key") is None:
        server = raw.get("server")
        if isinstance(server, dict):
            server.pop("key", None)
    for name, value in overrides.items():
        if value is None:
            continue
        table, key = OVERRIDES[name]
        if table == "":
            raw[key] = value
        else:
            _table(raw, _TABLE_PATHS.get(table, (table,)), source)[key] = value


# The override tables that are nested in the file: the modem's settings are [transport.modem].
_TABLE_PATHS: dict[str, tuple[str, ...]] = {"modem": ("transport", "modem")}


def _table(raw: dict[str, Any], path: tuple[str, ...], source: str) -> dict[str, Any]:
    """The (possibly nested) table at ``path`` in ``raw``, created empty if absent."""
    table = raw
    for depth, name in enumerate(path, start=1):
        table = table.setdefault(name, {})
        if not isinstance(table, dict):
            raise ConfigError(f"{source}: [{'.'.join(path[:depth])}] must be a table")
    return table


# --- 3. building -----------------------------------------------------------------------------

_TOP_LEVEL_KEYS = frozenset(
    {
        "server",
        "mavlink",
        "telemetry",
        "commands",
        "outbox",
        "transport",
        "sbd",
        "readings",
        "log_level",
    }
)


def _build_config(raw: dict[str, Any], source: str) -> Config:
    for key in raw:
        if key not in _TOP_LEVEL_KEYS:
            raise ConfigError(
                f"{source}: unknown setting {key!r} (known: {sorted(_TOP_LEVEL_KEYS)})"
            )
    transport = _build_transport(raw.get("transport", {}) or {}, source)
    log_level = _log_level(raw.get("log_level", "INFO"), source)
    return Config(
        server=_build(ServerConfig, raw.get("server", {}), f"{source}: [server]"),
        mavlink=_build(MavlinkConfig, raw.get("mavlink", {}), f"{source}: [mavlink]"),
        telemetry=_build_telemetry(raw.get("telemetry", {}) or {}, source),
        commands=_build(CommandsConfig, raw.get("commands", {}), f"{source}: [commands]"),
        outbox=_build(OutboxConfig, raw.get("outbox", {}), f"{source}: [outbox]"),
        transport=transport,
        sbd=_build(SbdLinkConfig, raw.get("sbd", {}), f"{source}: [sbd]"),
        readings=_readings(raw.get("readings", {}), source),
        log_level=log_level,
    )


def _build_telemetry(values: Any, source: str) -> TelemetryConfig:
    """[telemetry], with its channel table: ``channels = [{name = "...", step = 0.1}, ...]``."""
    where = f"{source}: [telemetry]"
    if not isinstance(values, dict):
        raise ConfigError(f"{where} must be a table")
    values = dict(values)
    table = values.pop("channels", [])
    telemetry = _build(TelemetryConfig, values, where, skip={"channels"})
    if telemetry.encoding not in TELEMETRY_ENCODINGS:
        known = ", ".join(TELEMETRY_ENCODINGS)
        raise ConfigError(f"{where} encoding: {telemetry.encoding!r} is not one of {known}")
    if not isinstance(table, list):
        raise ConfigError(f"{where} channels: expected a list of {{name, step}} tables")
    try:
        channels = tuple(channels_from(table))
    except CompactError as exc:
        raise ConfigError(f"{where} channels: {exc}") from None
    return replace(telemetry, channels=channels)


def _build_transport(values: Any, source: str) -> TransportConfig:
    """[transport] with its nested [transport.modem] table."""
    if not isinstance(values, dict):
        raise ConfigError(f"{source}: [transport] must be a table")
    values = dict(values)
    modem = _build(ModemConfig, values.pop("modem", {}), f"{source}: [transport.modem]")
    transport = _build(TransportConfig, values, f"{source}: [transport]", skip={"modem"})
    return replace(transport, modem=modem)


def _log_level(value: Any, source: str) -> str:
    if not isinstance(value, str) or value.upper() not in _LOG_LEVELS:
        raise ConfigError(f"{source}: log_level must be one of {', '.join(_LOG_LEVELS)}")
    return value.upper()


def _build(cls: type, values: Any, where: str, skip: frozenset[str] | set[str] = frozenset()):
    if not isinstance(values, dict):
        raise ConfigError(f"{where} must be a table")
    known = {f.name: f for f in fields(cls) if f.name not in skip}
    kwargs: dict[str, Any] = {}
    defaults = cls()
    for key, value in values.items():
        if key not in known:
            raise ConfigError(f"{where}: unknown key {key!r} (known: {', '.join(sorted(known))})")
        expected = type(getattr(defaults, key))
        kwargs[key] = _coerce(value, expected, f"{where} {key}")
    return cls(**kwargs)


def _coerce(value: Any, expected: type, where: str) -> Any:
    """``value`` as ``expected`` (bool, int, float or str), or a ConfigError naming ``where``."""
    # bool is an int subclass: check it first so `baud = true` is refused.
    if expected is bool:
        if isinstance(value, bool):
            return value
        raise ConfigError(f"{where}: expected true or false, got {value!r}")
    if isinstance(value, bool):
        raise ConfigError(f"{where}: expected {expected.__name__}, got {value!r}")
    coerce = _COERCIONS.get(expected)
    if coerce is None:
        raise ConfigError(f"{where}: unsupported value {value!r}")  # pragma: no cover
    return coerce(value, where)


def _as_int(value: Any, where: str) -> int:
    if isinstance(value, int):
        return value
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        return int(value)  # from a command-line flag
    raise ConfigError(f"{where}: expected a whole number, got {value!r}")


def _as_float(value: Any, where: str) -> float:
    if isinstance(value, int | float):
        return float(value)
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            pass
    raise ConfigError(f"{where}: expected a number, got {value!r}")


def _as_str(value: Any, where: str) -> str:
    if isinstance(value, str):
        return value
    raise ConfigError(f"{where}: expected a string, got {value!r}")


_COERCIONS: dict[type, Callable[[Any, str], Any]] = {int: _as_int, float: _as_float, str: _as_str}


def _readings(values: Any, source: str) -> tuple[ReadingSource, ...]:
    if not isinstance(values, dict):
        raise ConfigError(f"{source}: [readings] must be a table of tables")
    return tuple(
        _reading(name, spec, f"{source}: [readings.{name}]") for name, spec in values.items()
    )


def _reading(name: str, spec: Any, where: str) -> ReadingSource:
    if not isinstance(spec, dict):
        raise ConfigError(f"{where} must be a table with message, field and optional scale")
    unknown = set(spec) - {"message", "field", "scale"}
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}")
    if "message" not in spec or "field" not in spec:
        raise ConfigError(f"{where}: needs both message and field")
    message = _coerce(spec["message"], str, f"{where} message")
    if not message.isupper() or not message.replace("_", "").isalnum():
        raise ConfigError(f"{where} message: {message!r} is not a MAVLink message name")
    return ReadingSource(
        name=name,
        message=message,
        field=_coerce(spec["field"], str, f"{where} field"),
        scale=_coerce(spec.get("scale", 1.0), float, f"{where} scale"),
    )


# --- 4. the key ------------------------------------------------------------------------------


def _resolve_key(server: ServerConfig, source: str) -> str:
    if server.key:
        return server.key.strip()
    if server.key_file:
        try:
            return Path(server.key_file).read_text().strip()
        except OSError as exc:
            raise ConfigError(f"{source}: [server] key_file: cannot read: {exc}") from None
    return os.environ.get(KEY_ENV, "").strip()


# --- 5. cross-field checks -------------------------------------------------------------------


def _check(config: Config, source: str) -> None:
    _check_server(config.server, source)
    if not config.mavlink.connection:
        raise ConfigError(f"{source}: [mavlink] connection is required")
    _check_positive(config, source)
    _check_transport(config.transport, source)
    _check_sbd(config.sbd, source)
    if not config.outbox.path:
        raise ConfigError(f"{source}: [outbox] path is required")


def _check_server(server: ServerConfig, source: str) -> None:
    if not server.url:
        raise ConfigError(f"{source}: [server] url is required (or pass --server URL)")
    parts = urlsplit(server.url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise ConfigError(
            f"{source}: [server] url: {server.url!r} is not an http:// or https:// URL"
        )
    if not server.key:
        raise ConfigError(
            f"{source}: no vessel key: set [server] key or key_file, pass --key, or set ${KEY_ENV}"
        )


def _check_positive(config: Config, source: str) -> None:
    positive = {
        "[mavlink] baud": config.mavlink.baud,
        "[mavlink] stream_rate_hz": config.mavlink.stream_rate_hz,
        "[mavlink] silent_after_s": config.mavlink.silent_after_s,
        "[telemetry] period_s": config.telemetry.period_s,
        "[telemetry] batch_size": config.telemetry.batch_size,
        "[commands] poll_period_s": config.commands.poll_period_s,
        "[commands] arm_timeout_s": config.commands.arm_timeout_s,
        "[commands] ready_timeout_s": config.commands.ready_timeout_s,
        "[commands] acceptance_radius_m": config.commands.acceptance_radius_m,
        "[outbox] max_fixes": config.outbox.max_fixes,
        "[outbox] commit_every": config.outbox.commit_every,
        "[transport] timeout_s": config.transport.timeout_s,
        "[transport.modem] baud": config.transport.modem.baud,
    }
    for where, value in positive.items():
        if value <= 0:
            raise ConfigError(f"{source}: {where} must be greater than zero, got {value}")


def _check_transport(transport: TransportConfig, source: str) -> None:
    if transport.retries < 0 or transport.backoff_s < 0:
        raise ConfigError(f"{source}: [transport] retries and backoff_s cannot be negative")
    if transport.kind not in _TRANSPORT_KINDS:
        raise ConfigError(
            f"{source}: [transport] kind: {transport.kind!r} is not one of "
            f"{', '.join(_TRANSPORT_KINDS)}"
        )
    if transport.kind == "modem" and not transport.modem.trigger:
        raise ConfigError(f"{source}: [transport.modem] trigger cannot be empty")


def _check_sbd(sbd: SbdLinkConfig, source: str) -> None:
    if not sbd.port:
        return  # no modem: the other values are not used
    if sbd.baudrate <= 0 or sbd.period_s <= 0:
        raise ConfigError(f"{source}: [sbd] baudrate and period_s must be greater than zero")
    if sbd.fallback_after_s < 0:
        raise ConfigError(
            f"{source}: [sbd] fallback_after_s cannot be negative, got {sbd.fallback_after_s}"
        )
