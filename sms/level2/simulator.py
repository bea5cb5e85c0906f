"""A C&C box simulator (the Level 2 master), with fault injection, for tests and demos.

References (§ as in docs/level2.md#section-numbers-in-the-code):
* §9 the real sequence: enumerate to FF/FF, status polls at the declared period, request queued
  ~0.4 s after a flagged status reply, again ~0.25 s later while replies carry 0x8040;
* §10 no valid reply: resend the same tid about 2 s later, 3 attempts in all, then wait for the
  next period; one global tid counter for everything the C&C originates;
* §8.3 the no-fix (``FF 00 …``, zeros, 0x00) and fix ('Y' + coordinates) request forms;
* §8.6 the 0x8041 ACK/NAK queued message answering a command packet;
* §16 "C&C simulator for tests must": the fault list implemented by :data:`FAULTS`.

The simulator does no I/O of its own: it is given a :class:`Link` (send bytes / receive frames)
and a :class:`Clock`. With :class:`VirtualClock` protocol time is compressed: waiting for the
next period costs nothing, so an hour of polling runs in seconds of wall time while replies still
travel through real serial plumbing (``runner.SerialLink``).
"""

from __future__ import annotations

import random
import struct
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Protocol

from .bodies import (
    AckNakQueued,
    CommandPacket,
    Enumerate,
    EnumerationReply,
    ExtraInfo,
    QueuedReply,
    StatusReply,
    StatusRequest,
    summarize,
)
from .codec import (
    BROADCAST,
    CC_COMMAND,
    CC_MAIN,
    ESC,
    SOF,
    Address,
    Frame,
    MessageType,
    escape,
)
from .errors import BodyError
from .motion import Motion

RETRY_INTERVAL_S = 2.0  # §10: resend after ~1.9–2.0 s
ATTEMPTS = 3  # §10: three attempts in all
QUEUED_DELAY_S = 0.4  # §9: request queued ~0.43 s after a flagged status reply
QUEUED_GAP_S = 0.25  # §9: next request queued ~0.23–0.24 s after a 0x8040 reply
# Watching for a reply that must not come: the real PIB answered within 17 ms (§2), so a wrong
# answer would show up well inside this window.
SILENCE_WAIT_S = 0.2
DEFAULT_PERIOD_S = 20.0  # §8.2: the real PIB's declared period, until enumeration says otherwise
FIRST_TID = 0x0017  # §9: the capture's enumerate tid
UNKNOWN_TYPE = 0x0077  # not in §7: the payload must ignore it
FF_RUN_MAX = 256  # §2: the real line carried long 0xFF bursts; a few hundred bytes suffice here

# Faults that make the frame carrying a request invalid (no reply expected) and faults that
# keep it valid (a reply is expected). Extra frames (unknown type, other board, escaped length)
# are sent before an intact request.
BREAKING_FAULTS = ("bad_crc", "truncated", "bad_length")
KEEPING_FAULTS = ("ff_run", "split", "escapes", "duplicate", "lost_reply")
EXTRA_FAULTS = ("unknown_type", "other_board", "escaped_length")
FAULTS = BREAKING_FAULTS + KEEPING_FAULTS + EXTRA_FAULTS


class Clock(Protocol):
    def now(self) -> float: ...

    def sleep(self, seconds: float) -> None: ...


class RealClock:
    """Wall-clock time, for demos against a real payload."""

    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)


class VirtualClock:
    """Protocol time that jumps forward instead of waiting (compressed-time tests)."""

    def __init__(self, start: float = 0.0) -> None:
        self._now = start

    def now(self) -> float:
        return self._now

    def sleep(self, seconds: float) -> None:
        self._now += max(0.0, seconds)


class Link(Protocol):
    def send(self, data: bytes, *, split: bool = False) -> None:
        """Write bytes; ``split`` writes them one at a time."""
        ...

    def receive(self, timeout_s: float) -> Frame | None:
        """The next good frame within ``timeout_s`` seconds of real time, else None."""
        ...


def ack_all(_index: int, _packet: CommandPacket | None) -> int:
    """ACK every command (response code 0)."""
    return 0


def cycle_codes(index: int, _packet: CommandPacket | None) -> int:
    """Answer commands with codes 0, 1, 2, 3, 4, 0, … (§8.6), to exercise every NAK."""
    return index % 5


ACK_POLICIES: dict[str, Callable[[int, CommandPacket | None], int]] = {
    "ack": ack_all,
    "cycle": cycle_codes,
}


@dataclass
class SimConfig:
    """Timing (protocol seconds) and behaviour of the simulated C&C."""

    period_s: float | None = None  # None: the period the payload declares (§10)
    retry_interval_s: float = RETRY_INTERVAL_S
    attempts: int = ATTEMPTS
    queued_delay_s: float = QUEUED_DELAY_S
    queued_gap_s: float = QUEUED_GAP_S
    reply_wait_s: float = RETRY_INTERVAL_S  # real seconds to wait for a reply that must come
    silence_wait_s: float = SILENCE_WAIT_S  # real seconds to watch for a reply that must not
    position: tuple[float, float] | None = (36.803, -121.788)  # Moss Landing (§8.3), or None
    motion: Motion | None = None  # a glider that moves as commanded (instead of ``position``)
    ack_policy: Callable[[int, CommandPacket | None], int] = ack_all
    send_results: bool | None = None  # None: only if the payload asked (flag 0x08, §8.6)
    faults: Sequence[str] = ()
    fault_rate: float = 0.0
    seed: int = 0
    start_time: datetime | None = None  # GPS time at the start; None: the wall clock's


@dataclass
class SimStats:
    """What happened, for tests and the closing trace line."""

    enumerated: bool = False
    polls: int = 0
    attempts: int = 0
    valid_attempts: int = 0
    answered: int = 0
    unanswered: list[tuple[int, str]] = field(default_factory=list)
    unexpected_replies: list[str] = field(default_factory=list)
    stale_replies: int = 0
    duplicate_mismatches: int = 0
    queued_requests: int = 0
    commands: list[CommandPacket] = field(default_factory=list)
    command_tids: list[int] = field(default_factory=list)
    results_sent: Counter = field(default_factory=Counter)
    faults: Counter = field(default_factory=Counter)
    flagged_polls: int = 0

    def summary(self) -> str:
        return (
            f"polls={self.polls} attempts={self.attempts} answered={self.answered}/"
            f"{self.valid_attempts} unanswered={len(self.unanswered)} "
            f"unexpected={len(self.unexpected_replies)} commands={len(self.commands)} "
            f"results={dict(self.results_sent)} faults={dict(self.faults)}"
        )


class CcSimulator:
    """The master side. Call :meth:`run` (or :meth:`enumerate` and :meth:`poll_once`)."""

    def __init__(
        self,
        link: Link,
        config: SimConfig | None = None,
        clock: Clock | None = None,
        trace: Callable[[str], None] | None = None,
    ) -> None:
        self.link = link
        self.config = config or SimConfig()
        self.clock = clock or RealClock()
        self.trace = trace or (lambda _line: None)
        self.stats = SimStats()
        self.payload: Address | None = None
        self.period_s = self.config.period_s or DEFAULT_PERIOD_S
        self.payload_flags = 0
        self._tid = FIRST_TID
        self._clock_start = self.clock.now()
        self._start_time = self.config.start_time or datetime.now(UTC)
        self._rng = random.Random(self.config.seed)
        unknown = set(self.config.faults) - set(FAULTS)
        if unknown:
            raise ValueError(f"unknown faults {sorted(unknown)}; known: {', '.join(FAULTS)}")

    # -- the script -------------------------------------------------------------------------------

    def run(self, duration_s: float, on_tick: Callable[[float], None] | None = None) -> SimStats:
        """Enumerate, then poll for ``duration_s`` protocol seconds; ``on_tick(t)`` each period."""
        start = self.clock.now()
        while not self.enumerate():
            if self.clock.now() - start >= duration_s:
                return self.stats
        next_poll = self.clock.now() + self.period_s
        while True:
            self.clock.sleep(next_poll - self.clock.now())
            elapsed = self.clock.now() - start
            if elapsed >= duration_s:
                return self.stats
            if on_tick:
                on_tick(elapsed)
            self.poll_once()
            next_poll = max(next_poll + self.period_s, self.clock.now())

    def enumerate(self) -> bool:
        """Broadcast enumerate (§8.1) and learn the payload's address, period and flags."""
        reply = self._transact(MessageType.ENUMERATE, bytes(Enumerate()), BROADCAST)
        if reply is None:
            return False
        try:
            device = EnumerationReply.from_bytes(reply.body).devices[0]
        except BodyError as exc:
            self.stats.unexpected_replies.append(f"bad enumeration reply: {exc}")
            return False
        self.payload = Address(device.task, device.board)
        self.payload_flags = device.flags
        if self.config.period_s is None:
            self.period_s = float(max(1, device.poll_period_s))
        self.stats.enumerated = True
        return True

    def poll_once(self) -> None:
        """One status poll, and the queued-message exchange it may start (§9)."""
        assert self.payload is not None, "enumerate first"
        self.stats.polls += 1
        reply = self._transact(MessageType.REQUEST_STATUS, self._status_body(), self.payload)
        if reply is None:
            return
        try:
            status = StatusReply.from_bytes(reply.body)
        except BodyError as exc:
            self.stats.unexpected_replies.append(f"bad status reply: {exc}")
            return
        if status.block.queued:
            self.stats.flagged_polls += 1
            self.clock.sleep(self.config.queued_delay_s)
            self._drain_queue()

    def _drain_queue(self) -> None:
        assert self.payload is not None
        while True:
            self.stats.queued_requests += 1
            reply = self._transact(MessageType.REQUEST_QUEUED, b"", self.payload)
            if reply is None or reply.msg_type != MessageType.ACK:
                return  # no answer, or the NAK meaning "nothing queued" (§8.5)
            try:
                queued = QueuedReply.from_bytes(reply.body)
            except BodyError as exc:
                self.stats.unexpected_replies.append(f"bad queued reply: {exc}")
                return
            if reply.dest == Address(CC_COMMAND.task, CC_MAIN.board):
                self._command_received(reply.tid, queued.data)
            if not queued.more:
                return
            self.clock.sleep(self.config.queued_gap_s)

    def _command_received(self, tid: int, data: bytes) -> None:
        try:
            packet = CommandPacket.from_bytes(data[2:])
        except BodyError as exc:
            self.stats.unexpected_replies.append(f"bad command packet: {exc}")
            packet = None
        if packet is not None:
            self.stats.commands.append(packet)
            self.stats.command_tids.append(tid)
        wanted = self.config.send_results
        if wanted is None:
            # §8.6 [INF]: the C&C answers commands when the payload set "command ACK/NAK wanted"
            wanted = bool(self.payload_flags & ExtraInfo.COMMAND_ACK)
        # Unanswered, a command counts as accepted (code 0) for the glider's motion.
        code = (
            self.config.ack_policy(sum(self.stats.results_sent.values()), packet) if wanted else 0
        )
        if packet is not None and self.config.motion is not None and code == 0:
            doing = self.config.motion.obey(packet, self.clock.now())  # accepted: carried out
            if doing:
                self.trace(f"C&C glider: {doing}")
        if not wanted:
            return
        self.stats.results_sent[code] += 1
        # §8.6: type 0x8041 (no ACK wanted), from the C&C main task, tid from the counter.
        frame = Frame.make(
            MessageType.ACK_NAK_QUEUED,
            bytes(AckNakQueued(code)),
            tid=self._next_tid(),
            dest=self.payload or BROADCAST,
            src=CC_MAIN,
            no_ack=True,
        )
        self._send(bytes(frame), frame)
        self._expect_silence(frame.tid, "0x8041 must not be answered")

    # -- transactions and faults ------------------------------------------------------------------

    def _transact(self, msg_type: int, body: bytes, dest: Address) -> Frame | None:
        """Send a request up to ``attempts`` times with one tid; return the first valid reply."""
        tid = self._next_tid()
        fault = self._pick_fault()
        if fault == "escapes":
            tid = self._escaping_tid(msg_type, body, dest)
        frame = Frame.make(msg_type, body, tid=tid, dest=dest, src=CC_MAIN)
        started = self.clock.now()
        for attempt in range(self.config.attempts):
            if attempt:
                # §10: attempts start ~2 s apart; with a real clock the wait is part of that.
                self.clock.sleep(self.config.retry_interval_s - (self.clock.now() - started))
                fault = self._pick_fault(allow_escapes=False)
            started = self.clock.now()
            self.stats.attempts += 1
            intact = self._send_with_fault(frame, fault)
            if not intact:
                self._expect_silence(tid, f"answer to a broken {fault} frame")
                continue
            self.stats.valid_attempts += 1
            reply = self._wait_reply(frame, self.config.reply_wait_s)
            if reply is not None:
                self.stats.answered += 1
                if fault in ("duplicate", "lost_reply"):
                    self._check_retry_answer(frame, reply, fault)
                return reply
            self.stats.unanswered.append((tid, summarize(frame)))
        return None

    def _check_retry_answer(self, frame: Frame, reply: Frame, fault: str) -> None:
        """A repeated request (same tid) must get a byte-identical answer (§10, §16).

        ``duplicate``: the request went twice back to back, so a second answer is due now.
        ``lost_reply``: act as if the answer was lost on the line: resend after the retry
        interval, as the real C&C does.
        """
        self.stats.valid_attempts += 1
        if fault == "lost_reply":
            self.clock.sleep(self.config.retry_interval_s)
            self.stats.attempts += 1
            self._send(bytes(frame), frame, "retry after lost reply")
        second = self._wait_reply(frame, self.config.reply_wait_s)
        if second is None:
            self.stats.unanswered.append((frame.tid, summarize(frame)))
        elif bytes(second) != bytes(reply):
            self.stats.duplicate_mismatches += 1
        else:
            self.stats.answered += 1

    def _pick_fault(self, allow_escapes: bool = True) -> str | None:
        faults = [f for f in self.config.faults if allow_escapes or f != "escapes"]
        if not faults or self._rng.random() >= self.config.fault_rate:
            return None
        return self._rng.choice(faults)

    def _send_with_fault(self, frame: Frame, fault: str | None) -> bool:
        """Send ``frame`` damaged or decorated by ``fault``; True if it is still valid."""
        wire = bytes(frame)
        if fault:
            self.stats.faults[fault] += 1
        if fault in EXTRA_FAULTS:
            self._send_extra(fault)
        if fault == "bad_crc":
            unescaped = bytearray(frame.to_unescaped())
            unescaped[-1] ^= 1 << self._rng.randrange(8)
            self._send(unescaped[:1] + escape(bytes(unescaped[1:])), frame, fault)
            return False
        if fault == "truncated":
            self._send(wire[: self._rng.randrange(1, len(wire) - 1)], frame, fault)
            return False
        if fault == "bad_length":
            unescaped = bytearray(frame.to_unescaped())
            bad = self._rng.choice((5, 11, 559, 0xFFFF))  # §4: L < 12 or L > 558
            struct.pack_into("<H", unescaped, 1, bad)
            self._send(unescaped[:1] + escape(bytes(unescaped[1:])), frame, fault)
            return False
        if fault == "ff_run":
            run = b"\xff" * self._rng.randrange(1, FF_RUN_MAX)
            self._send(run + wire + run, frame, fault)
            return True
        if fault == "split":
            self._send(wire, frame, fault, split=True)
            return True
        if fault == "duplicate":
            self._send(wire + wire, frame, fault)
            return True
        self._send(wire, frame, fault)
        return True

    def _send_extra(self, fault: str) -> None:
        """Frames the payload must ignore, sent before an intact request."""
        target = self.payload or BROADCAST
        if fault == "unknown_type":
            extra = Frame.make(
                UNKNOWN_TYPE, b"\x01\x02", tid=self._next_tid(), dest=target, src=CC_MAIN
            )
        elif fault == "other_board":
            other = Address(target.task, (target.board + 1) % 0xFF)
            extra = Frame.make(
                MessageType.REQUEST_STATUS,
                self._status_body(),
                tid=self._next_tid(),
                dest=other,
                src=CC_MAIN,
            )
        else:  # escaped_length: L = 0x7E must be escaped on the wire (§16)
            body = bytes(0x7E - 12)
            extra = Frame.make(UNKNOWN_TYPE, body, tid=self._next_tid(), dest=target, src=CC_MAIN)
        self._send(bytes(extra), extra, fault)
        self._expect_silence(extra.tid, f"answer to {fault}")

    def _escaping_tid(self, msg_type: int, body: bytes, dest: Address) -> int:
        """A tid whose own bytes, or whose frame's CRC, need escaping (§16 edge cases)."""
        low = self._tid & 0xFF
        choice = self._rng.randrange(3)
        if choice == 0:
            return 0x7E00 | low  # high byte of the tid escaped
        if choice == 1:
            return (low << 8) | 0x7D  # low byte of the tid escaped
        for tid in range(self._tid, self._tid + 0x10000):  # a CRC byte escaped
            tid &= 0xFFFF
            crc = Frame.make(msg_type, body, tid=tid, dest=dest, src=CC_MAIN).to_unescaped()[-2:]
            if SOF in crc or ESC in crc:
                return tid
        return self._tid  # pragma: no cover - some tid always works

    # -- link helpers ------------------------------------------------------------------------------

    def _send(
        self, data: bytes, frame: Frame, fault: str | None = None, split: bool = False
    ) -> None:
        self.trace(f"C&C -> {summarize(frame)}{f' [{fault}]' if fault else ''}")
        self.link.send(bytes(data), split=split)

    def _wait_reply(self, request: Frame, wait_s: float) -> Frame | None:
        deadline = time.monotonic() + wait_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return None
            reply = self.link.receive(remaining)
            if reply is None:
                return None
            self.trace(f"PAY -> {summarize(reply)}")
            if reply.tid == request.tid and reply.src == (self.payload or reply.src):
                return reply
            self.stats.stale_replies += 1

    def _expect_silence(self, tid: int, what: str) -> None:
        """Nothing may arrive now: every request sent so far has been answered or is broken."""
        reply = self.link.receive(self.config.silence_wait_s)
        if reply is not None:
            self.trace(f"PAY -> {summarize(reply)} [unexpected]")
            self.stats.unexpected_replies.append(f"{what} (tid 0x{tid:04X}): {summarize(reply)}")

    def _status_body(self) -> bytes:
        """Alternate the no-fix and fix forms of the request (§8.3, §16)."""
        position = self.config.position
        if self.config.motion is not None:
            position = self.config.motion.position(self.clock.now())
        if position is None or self.stats.polls % 2:
            return bytes(StatusRequest())
        when = self._start_time + timedelta(seconds=self.clock.now() - self._clock_start)
        return bytes(StatusRequest.with_fix(when.replace(microsecond=0), *position))

    def _next_tid(self) -> int:
        tid = self._tid
        self._tid = (self._tid + 1) & 0xFFFF
        return tid
