"""The Iridium SBD modem driver: the only module here that opens ports (pyserial).

One call, :meth:`SbdModem.exchange`, is one SBD session as the boat sees it: write the
mobile-originated (MO) message if there is one (``AT+SBDWB``), run the session (``AT+SBDIX``, or
``AT+SBDIXA`` to answer a ring alert), retry a failed session with the contract's backoff as
far as its MO status allows (:mod:`.session_codes`), read the mobile-terminated (MT) message the
session brought (``AT+SBDRB``) and clear the MO buffer. All parsing lives in :mod:`.at`.

Buffers. The ISU keeps the MO buffer after a successful session and sends it again with the
next one: a mailbox check (``exchange(None)``) therefore clears it first (``AT+SBDD0``), and a
sent message is cleared at once. The MT buffer is emptied by the next session, so the MT
message is read before ``exchange`` returns (a bad frame is read again: reading is harmless).

Failure handling: one command at a time, each with a timeout; a timeout wakes and sets the modem
up again before the next command; a port that fails is closed and reopened by the next call;
lines nobody asked for (garbage, late answers) are logged and skipped; ``SBDRING`` may come at
any moment and is remembered (:attr:`SbdModem.ring_pending`). An answer to ``AT+SBDIX`` that
cannot be read counts as a failed attempt: its retry may send the MO message twice (a new
MOMSN), which the shore must tolerate.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import serial

from edge_client.contract.backoff import after_failures

from .at import (
    BAUDRATE,
    MO_MAX,
    BadFrame,
    Frame,
    SbdixResult,
    SbdReader,
    is_final,
    is_ring,
    parse_csq,
    parse_digit,
    parse_sbdix,
    with_checksum,
    write_meaning,
)
from .errors import (
    CommandError,
    MessageRefused,
    PortError,
    SbdError,
    SbdParseError,
    SbdTimeout,
    SessionFailed,
    WriteFailed,
)

log = logging.getLogger(__name__)

READ_TIMEOUT_S = 0.05  # one blocking read; bounds how late a deadline is noticed


@dataclass(frozen=True)
class SbdConfig:
    """Where the modem is and how patient to be. Times in seconds."""

    url: str
    baudrate: int = BAUDRATE
    command_timeout_s: float = 5.0  # AT, AT&K0, AT+SBDD…: well under a second
    csq_timeout_s: float = 60.0  # AT+CSQ measures first: seconds on a 9602
    write_timeout_s: float = 10.0  # READY … result: 342 bytes at 19200 baud take 0.2 s
    session_timeout_s: float = 90.0  # AT+SBDIX: typically 10–30 s, longer in a poor sky
    session_attempts: int = 5  # AT+SBDIX tries per exchange
    backoff_first_s: float = 10.0  # the first wait after a failed session; doubles
    backoff_cap_s: float = 300.0
    write_attempts: int = 3  # AT+SBDWB tries (a checksum answered 2 is noise on the line)
    read_attempts: int = 3  # AT+SBDRB tries (a frame whose checksum fails)
    wake_attempts: int = 3
    wake_timeout_s: float = 1.0
    settle_s: float = 0.2  # quiet time that lets late answers drain before the set-up
    flow_control: bool = False  # AT&K3 (RTS/CTS) or AT&K0 (the RockBLOCK's 3-wire serial)
    ring_alerts: bool = True  # AT+SBDMTA=1: SBDRING when the gateway holds an MT message
    min_signal: int = 0  # bars (AT+CSQ) needed before a session; 0 skips the check


@dataclass(frozen=True)
class SessionResult:
    """What one :meth:`SbdModem.exchange` achieved.

    ``momsn`` is the MO sequence number of the successful session (the shore's key, with the
    IMEI, for the message); ``mt`` the MT message it brought, or None; ``mt_queued`` how many
    more wait at the gateway (call ``exchange(None)`` again to fetch them); ``mt_lost`` says
    an MT message came but could not be read off the modem.
    """

    mo_sent: bool
    momsn: int
    mt: bytes | None
    mt_queued: int
    mtmsn: int | None = None
    mo_status: int = 0
    attempts: int = 1
    mt_lost: bool = False


def open_port(url: str, baudrate: int = BAUDRATE) -> Any:
    """A pyserial port: a device path, ``socket://host:port``, ``loop://``, any pyserial URL."""
    return serial.serial_for_url(url, baudrate=baudrate, timeout=READ_TIMEOUT_S)


def check_mo(data: bytes) -> bytes:
    """``data`` if the modem can send it (1 to 340 bytes), else MessageRefused."""
    if not isinstance(data, bytes | bytearray | memoryview):
        raise MessageRefused(f"an MO message is bytes, not {type(data).__name__}")
    data = bytes(data)
    if not 1 <= len(data) <= MO_MAX:
        raise MessageRefused(f"an MO message holds 1 to {MO_MAX} bytes, not {len(data)}")
    return data


class SbdModem:
    """An Iridium 9602/9603 (RockBLOCK) on a serial port. Not thread-safe: one caller.

    Typical use::

        with SbdModem("/dev/ttyUSB0") as modem:
            result = modem.exchange(payload)   # or exchange(None): a mailbox check
            if result.mt is not None:
                handle(result.mt)
    """

    def __init__(
        self,
        config: SbdConfig | str,
        *,
        port_factory: Callable[[str, int], Any] = open_port,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.config = SbdConfig(config) if isinstance(config, str) else config
        self.port_factory = port_factory
        self.clock = clock
        self.sleep = sleep
        self._port: Any = None
        self._reader = SbdReader()
        self._needs_setup = True
        self._ring = False
        self.rings = 0  # SBDRING lines seen
        self.noise_lines = 0  # lines logged and skipped
        self.sessions = 0  # AT+SBDIX[A] commands run
        self.opens = 0

    # -- life cycle -----------------------------------------------------------------------------

    def open(self) -> None:
        """Open the port and set the modem up (raises SbdError)."""
        self._ensure_ready()

    def close(self) -> None:
        port, self._port = self._port, None
        self._needs_setup = True
        if port is not None:
            try:
                port.close()
            except (serial.SerialException, OSError):
                pass

    def __enter__(self) -> SbdModem:
        self.open()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    @property
    def ring_pending(self) -> bool:
        """An SBDRING came and no mailbox check has answered it yet."""
        return self._ring

    # -- the public operations ------------------------------------------------------------------

    def exchange(self, mo: bytes | None, *, answer_ring: bool | None = None) -> SessionResult:
        """One SBD session: send ``mo`` (None: a mailbox check), receive what waits.

        ``answer_ring`` (default: whether a ring is pending) runs ``AT+SBDIXA``. Raises
        MessageRefused before any I/O for a message the modem cannot take, SessionFailed when
        the session failed for good (``permanent``) or ``session_attempts`` times, WriteFailed
        or SbdError when the modem cannot be brought to take the message.
        """
        data = check_mo(mo) if mo is not None else None
        failures = 0
        written = False
        while True:
            try:
                if not written and data is not None:
                    self.write_mo(data)
                elif not written:
                    self.clear_buffers(mo=True)  # a mailbox check must not resend the last
                written = True
                # A ring may have come while the message was written: answer it now.
                result = self._attempt(self._ring if answer_ring is None else answer_ring)
            except SbdError as exc:
                if exc.permanent:
                    raise
                written = written and self.ready  # a modem reset may have lost the buffer
                code, meaning, wait = -1, str(exc), 0.0
            else:
                status = result.mo
                if status.success:
                    return self._finish(result, data is not None, failures + 1)
                if status.permanent:
                    raise SessionFailed(result.mo_status, status.meaning, failures + 1, True)
                code, meaning, wait = result.mo_status, status.meaning, status.min_wait_s
            failures += 1
            if failures >= self.config.session_attempts:
                raise SessionFailed(code, meaning, failures, False)
            wait = max(wait, self._backoff(failures))
            log.warning("SBD session failed (%s: %s); next attempt in %.0f s", code, meaning, wait)
            self.sleep(wait)

    def write_mo(self, data: bytes) -> None:
        """Put ``data`` in the MO buffer (``AT+SBDWB``); a checksum answered 2 is written again."""
        data = check_mo(data)
        for attempt in range(1, self.config.write_attempts + 1):
            code = self._write_once(data)
            if code == 0:
                return
            log.warning("AT+SBDWB answered %d (%s), attempt %d", code, write_meaning(code), attempt)
            if code == 3 or attempt == self.config.write_attempts:
                raise WriteFailed(code, write_meaning(code))
        raise AssertionError("unreachable")  # pragma: no cover

    def clear_buffers(self, *, mo: bool = False, mt: bool = False) -> None:
        """Empty the MO and/or MT buffer (``AT+SBDD0``/``1``/``2``)."""
        kind = 2 if mo and mt else 0 if mo else 1
        lines = self.command(f"AT+SBDD{kind}")
        if self._number(lines, range(2), "AT+SBDD") != 0:
            raise CommandError(f"AT+SBDD{kind}", "1 (the buffer could not be cleared)")

    def session(self, *, answer_ring: bool = False) -> SbdixResult:
        """One ``AT+SBDIX`` (``AT+SBDIXA`` when answering a ring); no retries."""
        command = "AT+SBDIXA" if answer_ring else "AT+SBDIX"
        self.sessions += 1
        lines = self.command(command, self.config.session_timeout_s)
        for line in lines:
            try:
                return parse_sbdix(line)
            except SbdParseError:
                self._noise(line, f"in the answer to {command}")
        raise SbdParseError(f"no +SBDIX line in the answer to {command}", " | ".join(lines))

    def read_mt(self) -> bytes:
        """The MT buffer (``AT+SBDRB``), checksum verified; read again if it is not."""
        last = "no attempt"
        for _attempt in range(self.config.read_attempts):
            self._ensure_ready()
            self._start("AT+SBDRB")
            frame = self._wait_frame(self.clock() + self.config.command_timeout_s)
            if isinstance(frame, Frame):
                self._wait_final("AT+SBDRB", self.clock() + self.config.command_timeout_s)
                return frame.payload
            last = frame.reason
            log.warning("AT+SBDRB: %s; reading again", last)
            self._settle()
        raise SbdParseError(f"AT+SBDRB failed {self.config.read_attempts} times: {last}")

    def signal(self) -> int:
        """Signal strength in bars, 0–5 (``AT+CSQ``)."""
        lines = self.command("AT+CSQ", self.config.csq_timeout_s)
        for line in lines:
            try:
                return parse_csq(line)
            except SbdParseError:
                self._noise(line, "in the answer to AT+CSQ")
        raise SbdParseError("no +CSQ line in the answer", " | ".join(lines))

    def wait_for_ring(self, timeout: float) -> bool:
        """Wait up to ``timeout`` s for ``SBDRING`` (needs ``ring_alerts``); True if one came
        (or was already pending). Answer it with ``exchange(None)``."""
        self._ensure_ready()
        deadline = self.clock() + timeout
        while not self._ring and self.clock() < deadline:
            self._pump()
            while (line := self._reader.line()) is not None:
                if not self._take_ring(line):
                    self._noise(line, "while waiting for a ring")
        return self._ring

    def command(self, line: str, timeout: float | None = None) -> list[str]:
        """Run one AT command; its information lines. ``ERROR`` raises CommandError."""
        self._ensure_ready()
        return self._command(line, timeout or self.config.command_timeout_s)

    @property
    def ready(self) -> bool:
        return self._port is not None and not self._needs_setup

    # -- one exchange ---------------------------------------------------------------------------

    def _attempt(self, ring: bool) -> SbdixResult:
        if self.config.min_signal:
            bars = self.signal()
            if bars < self.config.min_signal:
                raise SbdError(f"signal {bars} bars, below {self.config.min_signal}")
        return self.session(answer_ring=ring)

    def _finish(self, result: SbdixResult, sent: bool, attempts: int) -> SessionResult:
        if result.mt_status != 2:
            self._ring = False  # a mailbox check without error answers the ring
        if sent:
            try:
                self.clear_buffers(mo=True)  # or the next session sends it again
            except SbdError as exc:
                log.warning("the MO buffer could not be cleared (%s); cleared before the next", exc)
        mt, lost = None, False
        if result.mt_received:
            try:
                mt = self.read_mt()
            except SbdError as exc:
                log.error("MT message %d arrived but could not be read: %s", result.mtmsn, exc)
                lost = True
            else:
                if len(mt) != result.mt_length:
                    log.warning("MT message is %d bytes, +SBDIX said %d", len(mt), result.mt_length)
        elif result.mt_status == 2:
            log.warning("SBD session: %s", result.mt_meaning)
        return SessionResult(
            mo_sent=sent,
            momsn=result.momsn,
            mt=mt,
            mt_queued=result.mt_queued,
            mtmsn=result.mtmsn if result.mt_received else None,
            mo_status=result.mo_status,
            attempts=attempts,
            mt_lost=lost,
        )

    def _backoff(self, failures: int) -> float:
        config = self.config
        return after_failures(config.backoff_first_s, failures - 1, cap=config.backoff_cap_s)

    def _write_once(self, data: bytes) -> int:
        command = f"AT+SBDWB={len(data)}"
        self._ensure_ready()
        self._start(command)
        deadline = self.clock() + self.config.command_timeout_s
        while True:  # READY, or a result at once (3: a size the modem refuses)
            line = self._next_line(command, deadline)
            if line.upper() == "READY":
                break
            if line.upper() == "ERROR":
                raise CommandError(command, line)
            try:
                code = parse_digit(line, range(4))
            except SbdParseError:
                self._noise(line, f"in the answer to {command}")
                continue
            self._wait_final(command, deadline)
            return code
        self._write(with_checksum(data))
        deadline = self.clock() + self.config.write_timeout_s
        while True:
            line = self._next_line(command, deadline)
            try:
                code = parse_digit(line, range(4))
            except SbdParseError:
                self._noise(line, f"after the message of {command}")
                continue
            if code != 1:  # the ISU sends no OK after 1 (a documented quirk)
                self._wait_final(command, deadline)
            return code

    # -- set-up and recovery --------------------------------------------------------------------

    def _ensure_ready(self) -> None:
        if self.ready:
            return
        if self._port is None:
            try:
                self._port = self.port_factory(self.config.url, self.config.baudrate)
            except (serial.SerialException, OSError, ValueError) as exc:
                raise PortError(f"cannot open {self.config.url}: {exc}") from None
            self._reader = SbdReader()
            self.opens += 1
        self._wake()
        self._settle()
        timeout = self.config.command_timeout_s
        self._command("ATE0", timeout)
        self._command("AT&K3" if self.config.flow_control else "AT&K0", timeout)
        self._command("AT&D0", timeout)  # a RockBLOCK leaves DTR unwired
        self._command("AT+SBDMTA=1" if self.config.ring_alerts else "AT+SBDMTA=0", timeout)
        self._needs_setup = False
        log.info("SBD modem on %s ready", self.config.url)

    def _wake(self) -> None:
        for _attempt in range(self.config.wake_attempts):
            try:
                self._command("AT", self.config.wake_timeout_s)
                return
            except SbdTimeout:
                continue
            except CommandError:
                return  # it listens: ERROR is an answer
        raise SbdTimeout(f"no answer to AT after {self.config.wake_attempts} attempts")

    def _settle(self) -> None:
        """Let late answers arrive and drop them, until the line is quiet for ``settle_s``."""
        quiet_until = self.clock() + self.config.settle_s
        limit = self.clock() + 10 * self.config.settle_s
        while self.clock() < min(quiet_until, limit):
            if self._pump():
                quiet_until = self.clock() + self.config.settle_s
        while (line := self._reader.line()) is not None:
            if not self._take_ring(line):
                self._noise(line, "late, dropped")
        if self._reader.pending:
            self._noise(self._reader.clear().decode("latin-1"), "late, dropped")

    # -- one command ----------------------------------------------------------------------------

    def _command(self, command: str, timeout: float) -> list[str]:
        self._start(command)
        deadline = self.clock() + timeout
        lines: list[str] = []
        while True:
            line = self._next_line(command, deadline)
            if line.upper() == "OK":
                return lines
            if line.upper() == "ERROR":
                raise CommandError(command, line)
            lines.append(line)

    def _start(self, command: str) -> None:
        if self._port is None:
            raise PortError("port closed")
        self._write(command.encode("ascii") + b"\r")

    def _next_line(self, command: str, deadline: float) -> str:
        """The next line of ``command``'s answer: echoes and rings taken out."""
        while True:
            line = self._reader.line()
            if line is None:
                if self.clock() >= deadline:
                    self._timed_out()
                    raise SbdTimeout(f"no answer to {command} within the timeout")
                self._pump()
                continue
            if self._take_ring(line) or line.upper() == command.upper():
                continue
            return line

    def _wait_final(self, command: str, deadline: float) -> None:
        while not is_final(line := self._next_line(command, deadline)):
            self._noise(line, f"before the result of {command}")
        if line.upper() != "OK":
            raise CommandError(command, line)

    def _wait_frame(self, deadline: float) -> Frame | BadFrame:
        while True:
            item = self._reader.frame()
            if isinstance(item, Frame | BadFrame):
                return item
            if isinstance(item, str):
                if item.upper() == "ERROR":
                    raise CommandError("AT+SBDRB", item)
                if not self._take_ring(item) and item.upper() != "AT+SBDRB":
                    self._noise(item, "before the frame of AT+SBDRB")
                continue
            if self.clock() >= deadline:
                self._timed_out()
                raise SbdTimeout("no frame from AT+SBDRB within the timeout")
            self._pump()

    def _timed_out(self) -> None:
        self._needs_setup = True
        dropped = self._reader.clear()
        if dropped:
            self._noise(dropped.decode("latin-1"), "partial answer at a timeout")

    def _take_ring(self, line: str) -> bool:
        if not is_ring(line):
            return False
        if not self._ring:
            log.info("SBDRING: an MT message waits at the gateway")
        self._ring = True
        self.rings += 1
        return True

    def _noise(self, text: str, where: str) -> None:
        self.noise_lines += 1
        log.info("SBD modem noise (%s): %r", where, text[:80])

    @staticmethod
    def _number(lines: list[str], allowed: range, command: str) -> int:
        for line in lines:
            try:
                return parse_digit(line, allowed)
            except SbdParseError:
                continue
        raise SbdParseError(f"no result in the answer to {command}", " | ".join(lines))

    # -- bytes ----------------------------------------------------------------------------------

    def _pump(self) -> bool:
        """One read (blocking up to READ_TIMEOUT_S) into the reader; True if bytes came."""
        port = self._port
        if port is None:
            raise PortError("port closed")
        try:
            data = port.read(1)
            while data and port.in_waiting:
                data += port.read(port.in_waiting)
        except (serial.SerialException, OSError) as exc:
            self._port_failed(exc)
        if data:
            self._reader.feed(data)
        return bool(data)

    def _write(self, data: bytes) -> None:
        port = self._port
        if port is None:
            raise PortError("port closed")
        try:
            port.write(data)
            port.flush()
        except (serial.SerialException, OSError) as exc:
            self._port_failed(exc)

    def _port_failed(self, exc: Exception) -> None:
        log.warning("SBD modem port %s failed: %s", self.config.url, exc)
        self.close()
        raise PortError(f"port {self.config.url} failed: {exc}") from None
