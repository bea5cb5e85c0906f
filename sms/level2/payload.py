"""The payload side of Level 2 as a pure state machine: frames in, frames out.

References (§ as in docs/level2.md#section-numbers-in-the-code):
* §8.1–§8.2 answer enumerate (also sent to broadcast FF/FF) with this payload's device block;
* §8.3–§8.4 answer request status with the status block; bit 15 of ``version`` when a command
  waits; record the C&C's time and position (the glider's fix);
* §8.5 answer request queued with the next command for the C&C command task (0x01), orig type
  0x8040 while more remain; with nothing queued, the NAK ACFR read in the handbook;
* §8.6 the C&C's ACK/NAK queued message becomes the command's result; never ACK a frame with
  bit 15 (no ACK requested) set; §8.8 power notices (0x0030) are logged, layout unknown;
* §10 the C&C retries with the same transaction id: answer identically, hand a command over once;
* §16 "Payload behaviour" and "Unknown message type ... don't crash, don't reply".

No I/O and no clock: :meth:`PayloadMachine.handle` takes a decoded :class:`Frame` and returns the
frames to write. Everything else that happened (fixes, results, power notices, ignored frames) is
queued as a notification for the runner to log or act on (:meth:`PayloadMachine.notifications`).
"""

from __future__ import annotations

import itertools
import threading
from collections import OrderedDict, deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from datetime import datetime
from typing import Protocol

from .bodies import (
    COMMAND_FORMAT,
    NAK_INVALID,
    QUEUED_FLAG,
    STATUS_VERSION,
    Ack,
    AckNakQueued,
    DeviceInfo,
    EnumerationReply,
    ExtraInfo,
    InnerResponse,
    Nak,
    QueuedReply,
    StatusBlock,
    StatusReply,
    StatusRequest,
    l2_to_degrees,
    response_meaning,
)
from .codec import BROADCAST, CC_COMMAND, Address, Frame, MessageType
from .errors import BodyError
from .inner import InnerCommand, InnerCommandTable

REPLY_CACHE_SIZE = 8  # retries come within ~6 s (§10); a few recent replies are plenty
# §8.6: the one real 0x8041 was addressed to task 0x10, board 0 (unexplained); accept it too.
CAPTURED_RESULT_ADDRESS = Address(0x10, 0x00)
CUSTOMER_DEVICE_TYPE = 0x1001  # §8.2: 0x1001–0x7FFF are for customers (Goby uses 0x1001)


# --- configuration and state ------------------------------------------------------------------


def _always(_body: bytes) -> bool:
    return True


@dataclass(frozen=True)
class PayloadConfig:
    """What this payload announces (§8.2) and how it behaves where the sources disagree."""

    address: Address = Address(0x00, 0x01)  # the real PIB's task/board (§6)
    device_type: int = CUSTOMER_DEVICE_TYPE
    serial: str = "000001"
    description: str = "Shoreside payload"
    poll_period_s: int = 20  # §8.2/§10: the C&C polls at the declared period
    # §8.2: 0x08 asks the C&C to ACK/NAK our commands (§8.6 "presumably" needs it).
    flags: int = ExtraInfo.COMMAND_ACK | ExtraInfo.POWER
    firmware: tuple[int, int, int] = (0, 1, 0)
    nak_empty_queue: bool = True  # §8.5: ACFR's NAK; False = stay silent like Goby
    # §8.8: the power notice layout is unknown; this decides which notices mean "power down".
    is_power_down: Callable[[bytes], bool] = _always
    result_addresses: frozenset[Address] = frozenset({CAPTURED_RESULT_ADDRESS})

    def device_info(self) -> DeviceInfo:
        major, minor, revision = self.firmware
        return DeviceInfo(
            version=1,
            device_type=self.device_type,
            task=self.address.task,
            board=self.address.board,
            serial=self.serial.encode("ascii")[:6].rjust(6, b"0"),
            poll_period_s=self.poll_period_s,
            flags=self.flags,
            fw_major=major,
            fw_minor=minor,
            fw_revision=revision,
            description=DeviceInfo.pad_description(self.description),
        )


@dataclass
class SensorState:
    """Readings for the status block (§8.4); None means unknown and is sent as 0."""

    leak1: int | None = None
    leak2: int | None = None
    humidity_temp_c: float | None = None
    humidity_pct: float | None = None
    pressure_temp_c: float | None = None
    pressure_kpa: float | None = None
    alarms: int = 0

    def block(self, address: Address, queued: bool) -> StatusBlock:
        def byte(value: float | None) -> int:
            # The block holds unsigned bytes (§8.4, capture); out-of-range readings are clamped.
            return 0 if value is None else max(0, min(0xFF, round(value)))

        return StatusBlock(
            version=STATUS_VERSION | (QUEUED_FLAG if queued else 0),
            task=address.task,
            board=address.board,
            alarms=self.alarms & 0xFFFF,
            leak1=byte(self.leak1),
            leak2=byte(self.leak2),
            humidity_temp_c=byte(self.humidity_temp_c),
            humidity_pct=byte(self.humidity_pct),
            pressure_temp_c=byte(self.pressure_temp_c),
            pressure_kpa=byte(self.pressure_kpa),
        )


# --- commands: source interface, in-memory queue, results --------------------------------------


@dataclass(frozen=True)
class QueuedCommand:
    """A command waiting to go to the C&C command task, with the caller's identifier."""

    ident: str
    command: InnerCommand

    def queued_data(self) -> bytes:
        """Command format 1 then the inner packet (§11.1)."""
        return COMMAND_FORMAT.to_bytes(2, "little") + bytes(self.command.packet)


@dataclass(frozen=True)
class CommandResult:
    """What the C&C said about a command (§8.6): done, or failed with the code's meaning."""

    ident: str
    code: int
    meaning: str
    response: InnerResponse | None = None

    @property
    def done(self) -> bool:
        return self.code == 0


class CommandSource(Protocol):
    """Where commands come from. The bridge's database-backed source implements the same."""

    def pending_count(self) -> int:
        """Commands waiting to be handed over."""
        ...

    def take_next(self) -> QueuedCommand | None:
        """Remove and return the next command (it is being handed over now)."""
        ...

    def complete(self, result: CommandResult) -> None:
        """Record the C&C's answer about a handed-over command."""
        ...


class MemoryCommandSource:
    """A thread-safe in-memory FIFO: the runner thread takes, other threads add."""

    def __init__(self, table: InnerCommandTable | None = None) -> None:
        self.table = table or InnerCommandTable.load()
        self._lock = threading.Lock()
        self._pending: deque[QueuedCommand] = deque()
        self._ids = itertools.count(1)
        self.handed_over: list[str] = []
        self.results: dict[str, CommandResult] = {}

    def add(self, command: str | InnerCommand, ident: str | None = None) -> QueuedCommand:
        """Queue a command given as text (``"fhead 230"``, checked by the table) or encoded."""
        if isinstance(command, str):
            command = self.table.parse(command)  # raises CommandRefused
        with self._lock:
            queued = QueuedCommand(ident or f"cmd-{next(self._ids)}", command)
            self._pending.append(queued)
        return queued

    def pending_count(self) -> int:
        with self._lock:
            return len(self._pending)

    def take_next(self) -> QueuedCommand | None:
        with self._lock:
            if not self._pending:
                return None
            queued = self._pending.popleft()
            self.handed_over.append(queued.ident)
            return queued

    def complete(self, result: CommandResult) -> None:
        with self._lock:
            self.results[result.ident] = result


# --- notifications ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Fix:
    """The glider's position and time as the C&C reported them in a status request (§8.3)."""

    time: datetime | None
    lat: float
    lon: float


@dataclass(frozen=True)
class Enumerated:
    cc: Address


@dataclass(frozen=True)
class FixReceived:
    fix: Fix


@dataclass(frozen=True)
class CommandHandedOver:
    ident: str
    text: str
    tid: int


@dataclass(frozen=True)
class CommandCompleted:
    result: CommandResult


@dataclass(frozen=True)
class ResultWithoutCommand:
    code: int


@dataclass(frozen=True)
class PowerNotice:
    body: bytes


@dataclass(frozen=True)
class PowerDown:
    body: bytes


@dataclass(frozen=True)
class Ignored:
    frame: Frame
    reason: str


Notification = (
    Enumerated
    | FixReceived
    | CommandHandedOver
    | CommandCompleted
    | ResultWithoutCommand
    | PowerNotice
    | PowerDown
    | Ignored
)


# --- the machine ----------------------------------------------------------------------------------


@dataclass
class _Route:
    handler: str
    broadcast_ok: bool  # accepted when sent to FF/FF as well as to us
    may_reply: bool  # False for one-way notices: never answer them


# The transition table (h11 _state.py style): message type → who handles it, whether it is
# accepted on broadcast, and whether it can be answered at all. Types not listed are ignored.
ROUTES: dict[int, _Route] = {
    MessageType.ENUMERATE: _Route("_on_enumerate", broadcast_ok=True, may_reply=True),
    MessageType.REQUEST_STATUS: _Route("_on_status", broadcast_ok=False, may_reply=True),
    MessageType.REQUEST_QUEUED: _Route("_on_queued", broadcast_ok=False, may_reply=True),
    MessageType.ACK_NAK_QUEUED: _Route("_on_result", broadcast_ok=False, may_reply=True),
    MessageType.POWER: _Route("_on_power", broadcast_ok=True, may_reply=False),
    MessageType.CC_TELEMETRY: _Route("_on_logged", broadcast_ok=True, may_reply=False),
    MessageType.SEND_FORWARD: _Route("_on_logged", broadcast_ok=True, may_reply=False),
    MessageType.NAK: _Route("_on_logged", broadcast_ok=False, may_reply=False),
    MessageType.ACK: _Route("_on_logged", broadcast_ok=False, may_reply=False),
}


class PayloadMachine:
    """The payload slave. ``handle(frame)`` returns the frames to send (often none)."""

    def __init__(
        self,
        config: PayloadConfig | None = None,
        *,
        source: CommandSource,
        sensors: SensorState | None = None,
    ) -> None:
        # The caller chooses the command source (a MemoryCommandSource with its table, or the
        # bridge's database-backed one): the machine itself opens no file and takes no lock.
        self.config = config or PayloadConfig()
        self.source = source
        self.sensors = sensors or SensorState()
        self.latest_fix: Fix | None = None
        self.enumerated = False
        self._device = self.config.device_info()
        self._replies: OrderedDict[tuple, list[Frame]] = OrderedDict()
        self._awaiting_result: deque[QueuedCommand] = deque()
        self._notes: deque[Notification] = deque()

    # -- public ---------------------------------------------------------------------------------

    def handle(self, frame: Frame) -> list[Frame]:
        """Process one decoded frame and return the frames to write, in order.

        1. Ignore frames not addressed to us (or to broadcast where the type allows it).
        2. A retry (same source, type, tid and body as a recent request) gets the same answer,
           with no side effects: a command is never handed over twice.
        3. Otherwise dispatch on the transition table; bodies that do not parse are ignored.
        4. Drop every reply if the request asked for no ACK (bit 15).
        """
        route = ROUTES.get(frame.msg_type)
        if route is None:
            return self._ignore(frame, "unknown message type")
        if not self._for_us(frame, route):
            return self._ignore(frame, f"addressed to {frame.dest}")
        key = (frame.src, frame.type_word, frame.tid, frame.body)
        cached = self._replies.get(key) if frame.msg_type != MessageType.ENUMERATE else None
        if cached is not None:
            return list(cached)
        try:
            replies = getattr(self, route.handler)(frame)
        except BodyError as exc:
            return self._ignore(frame, f"bad body: {exc}")
        if frame.no_ack or not route.may_reply:
            replies = []  # §5/§8.6: never answer a frame that asked for no ACK
        if route.may_reply and not frame.no_ack:
            self._remember(key, replies)
        return replies

    def notifications(self) -> list[Notification]:
        """Take everything that happened since the last call (fixes, results, notices…)."""
        notes = list(self._notes)
        self._notes.clear()
        return notes

    @property
    def awaiting_result(self) -> list[str]:
        """Idents of commands handed over whose ACK/NAK has not come yet."""
        return [q.ident for q in self._awaiting_result]

    # -- handlers --------------------------------------------------------------------------------

    def _on_enumerate(self, frame: Frame) -> list[Frame]:
        # A (re)started C&C may restart its tid counter: earlier answers must not be replayed.
        # (Enumerate itself bypasses the retry cache in handle(); its answer never changes.)
        self._replies.clear()
        self.enumerated = True
        self._notes.append(Enumerated(frame.src))
        body = bytes(EnumerationReply((self._device,)))
        return [frame.reply(MessageType.ACK, body, src=self.config.address)]

    def _on_status(self, frame: Frame) -> list[Frame]:
        request = StatusRequest.from_bytes(frame.body)
        if request.valid:
            lat, lon = l2_to_degrees(request.lat), l2_to_degrees(request.lon)
            self.latest_fix = Fix(request.utc, lat, lon)
            self._notes.append(FixReceived(self.latest_fix))
        queued = self.source.pending_count() > 0
        block = self.sensors.block(self.config.address, queued)
        return [frame.reply(MessageType.ACK, bytes(StatusReply(block)), src=self.config.address)]

    def _on_queued(self, frame: Frame) -> list[Frame]:
        if frame.no_ack:
            return []  # the answer could not be sent, so nothing may be taken for it
        queued = self.source.take_next()
        if queued is None:
            if not self.config.nak_empty_queue:
                return []
            body = bytes(Nak(MessageType.REQUEST_QUEUED, NAK_INVALID, b"\x00\x00"))
            return [frame.reply(MessageType.NAK, body, src=self.config.address)]
        self._awaiting_result.append(queued)
        self._notes.append(CommandHandedOver(queued.ident, queued.command.text, frame.tid))
        more = self.source.pending_count() > 0
        body = bytes(QueuedReply(queued.queued_data(), more))
        # §8.5: the reply goes to the C&C task the data is for: commands to task 0x01.
        dest = Address(CC_COMMAND.task, frame.src_board)
        return [frame.reply(MessageType.ACK, body, src=self.config.address, dest=dest)]

    def _on_result(self, frame: Frame) -> list[Frame]:
        answer = AckNakQueued.from_bytes(frame.body)
        if self._awaiting_result:
            # Results carry no reference to the command; the C&C answers in order (§8.6).
            queued = self._awaiting_result.popleft()
            result = CommandResult(
                queued.ident, answer.code, response_meaning(answer.code), answer.response
            )
            self.source.complete(result)
            self._notes.append(CommandCompleted(result))
        else:
            self._notes.append(ResultWithoutCommand(answer.code))
        # ACFR ACKs a 0x0041 that wants one: orig type, command format (§8.6).
        body = bytes(Ack(MessageType.ACK_NAK_QUEUED, COMMAND_FORMAT.to_bytes(2, "little")))
        return [frame.reply(MessageType.ACK, body, src=self.config.address)]

    def _on_power(self, frame: Frame) -> list[Frame]:
        self._notes.append(PowerNotice(frame.body))
        if self.config.is_power_down(frame.body):
            self._notes.append(PowerDown(frame.body))
        return []

    def _on_logged(self, frame: Frame) -> list[Frame]:
        self._notes.append(Ignored(frame, "logged only (no reply for this type)"))
        return []

    # -- helpers ---------------------------------------------------------------------------------

    def _for_us(self, frame: Frame, route: _Route) -> bool:
        if frame.dest == self.config.address:
            return True
        if route.broadcast_ok and frame.dest == BROADCAST:
            return True
        return (
            frame.msg_type == MessageType.ACK_NAK_QUEUED
            and frame.dest in self.config.result_addresses
        )

    def _ignore(self, frame: Frame, reason: str) -> list[Frame]:
        self._notes.append(Ignored(frame, reason))
        return []

    def _remember(self, key: tuple, replies: Iterable[Frame]) -> None:
        self._replies[key] = list(replies)
        while len(self._replies) > REPLY_CACHE_SIZE:
            self._replies.popitem(last=False)


__all__ = [
    "CommandCompleted",
    "CommandHandedOver",
    "CommandResult",
    "CommandSource",
    "Enumerated",
    "Fix",
    "FixReceived",
    "Ignored",
    "MemoryCommandSource",
    "Notification",
    "PayloadConfig",
    "PayloadMachine",
    "PowerDown",
    "PowerNotice",
    "QueuedCommand",
    "ResultWithoutCommand",
    "SensorState",
]
