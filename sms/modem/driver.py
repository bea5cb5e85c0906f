"""The GSM modem driver: the only module here that opens ports (pyserial ``serial_for_url``).

References: docs/sms.md, 'The GSM modem' (set-up, receiving, sending, errors, what a robust
driver does); 3GPP TS 27.005 §3.5.1 (+CMGS prompt, Ctrl-Z, ESC). The only port module: this
module moves bytes between the port and :class:`~.at.AtReader`; all parsing lives in ``at.py``.

THE DELETE CONTRACT. The SIM is the queue. A message is deleted from the modem
(:meth:`Modem.delete`) only AFTER the caller has stored it durably (database commit). If the
process, the modem or the port dies in between, the message is still on the SIM and is found
again by :meth:`Modem.stored_messages` (the caller then sees it twice and must store it
idempotently, keyed on ``ReceivedSms.key``: number, text and modem timestamp). That is why the
set-up uses ``AT+CNMI=2,1,0,0,0`` (store, then announce with +CMTI) and never ``2,2`` (push
the text as +CMT without storing it). :func:`receive_all` implements the contract.

Failure handling:
* one command in flight at a time, each with a timeout; +CMTI lines that arrive at any time,
  also in the middle of another command's answer, are kept for :meth:`Modem.poll_events`;
* a timeout, or the power-up burst (``RDY`` …) mid-session, marks the modem for a bounded reset
  (``AT`` until it answers, drain late answers, ``ATE0``, the set-up again) before the next
  command, and the caller is told to re-list stored messages (``ModemEvents.relist``);
* a port that fails (USB unplugged, socket peer gone) is closed and reopened with backoff.
"""

from __future__ import annotations

import dataclasses
import logging
import re
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import serial

from edge_client.contract.backoff import doubled
from sms import gsm7

from .at import (
    CTRL_Z,
    ESC,
    AtReader,
    Echo,
    Event,
    Noise,
    Prompt,
    ReceivedSms,
    Response,
    Urc,
    parse_cmgs,
    parse_cmti,
    parse_cpms,
)
from .errors import (
    AtParseError,
    CommandError,
    ModemError,
    ModemRestarted,
    ModemTimeout,
    ModemUsageError,
    PinRequired,
    PortError,
    SendUnconfirmed,
    UnsendableText,
)

log = logging.getLogger(__name__)

BAUDRATE = 115_200  # the usual default of Quectel/SIMCom USB and UART ports
READ_TIMEOUT_S = 0.05  # one blocking read; bounds how late a deadline is noticed
COMMAND_TIMEOUT_S = 5.0  # most commands answer in well under a second
LIST_TIMEOUT_S = 20.0  # AT+CMGL of a full SIM (50 messages) on a slow module
SEND_TIMEOUT_S = 60.0  # docs/sms.md: +CMGS may take several seconds (network round trip)
WAKE_TIMEOUT_S = 1.0  # per "AT" while waking a modem; it may ignore commands after power-up
WAKE_ATTEMPTS = 5
SETTLE_S = 0.3  # quiet time that lets late answers to abandoned commands drain away
DRAIN_LIMIT = 10  # a chatty modem (URCs all the time) must not keep the drain going forever
RESET_ATTEMPTS = 3  # set-up attempts per recovery before backing off
RECONNECT_DELAY_S = 1.0  # first backoff; doubles up to RECONNECT_MAX_S
RECONNECT_MAX_S = 60.0
RELIST_INTERVAL_S = 600.0  # periodic AT+CMGL: catches a +CMTI lost while the modem was deaf
SMS_SEPTETS = gsm7.SMS_SEPTETS
NUMBER = re.compile(r"^\+?[0-9]{3,20}$")
# Bytes that cannot be typed after the "> " prompt in text mode: Ctrl-Z (0x1A, GSM 'Ξ') would
# send early and ESC (0x1B, the GSM-7 extension escape) abandons the message (TS 27.005 §3.5.1).
_UNTYPEABLE = {CTRL_Z[0], ESC[0]}


@dataclass(frozen=True)
class ModemConfig:
    """Where the modem is and how patient to be. Times in seconds."""

    url: str
    baudrate: int = BAUDRATE
    storage: str = "SM"  # AT+CPMS: "SM" the SIM, "ME" the modem's own memory
    command_timeout_s: float = COMMAND_TIMEOUT_S
    list_timeout_s: float = LIST_TIMEOUT_S
    send_timeout_s: float = SEND_TIMEOUT_S
    wake_timeout_s: float = WAKE_TIMEOUT_S
    wake_attempts: int = WAKE_ATTEMPTS
    settle_s: float = SETTLE_S
    reset_attempts: int = RESET_ATTEMPTS
    reconnect_delay_s: float = RECONNECT_DELAY_S
    reconnect_max_s: float = RECONNECT_MAX_S
    relist_interval_s: float | None = RELIST_INTERVAL_S


@dataclass(frozen=True)
class ModemEvents:
    """What :meth:`Modem.poll_events` saw: indices announced by +CMTI, and whether to re-list.

    ``relist`` is True after the first set-up, after any reset, restart or reconnect, and every
    ``relist_interval_s``: messages may have arrived unannounced, so call ``stored_messages``.
    """

    indices: tuple[int, ...] = ()
    relist: bool = False


def open_port(url: str, baudrate: int = BAUDRATE) -> Any:
    """A pyserial port: a device path, ``socket://host:port``, ``loop://``, any pyserial URL."""
    return serial.serial_for_url(url, baudrate=baudrate, timeout=READ_TIMEOUT_S)


class Modem:
    """A text-mode SMS modem on a serial port. Not thread-safe: one caller, one command at a time.

    Typical use (see :func:`receive_all`)::

        with Modem(ModemConfig("/dev/ttyUSB2")) as modem:
            while running:
                events = modem.poll_events(timeout=1.0)
                receive_all(modem, store, events)
    """

    def __init__(
        self,
        config: ModemConfig | str,
        *,
        port_factory: Callable[[str, int], Any] = open_port,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.config = ModemConfig(config) if isinstance(config, str) else config
        self.port_factory = port_factory
        self.clock = clock
        self._port: Any = None
        self._reader = AtReader()
        self._pending: list[int] = []
        self._needs_setup = True
        self._relist = False
        self._last_list = 0.0
        self._retry_at = 0.0
        self._backoff = self.config.reconnect_delay_s
        self.store_usage: tuple[int, int] | None = None  # (used, total) from +CPMS
        self.opens = 0
        self.resets = 0
        self.restarts_seen = 0
        self.noise_lines = 0

    # -- life cycle -----------------------------------------------------------------------------

    def open(self) -> None:
        """Open the port and set the modem up (raises ModemError; PinRequired is permanent)."""
        self._ensure_ready()

    def close(self) -> None:
        """Close the port. The next call reopens it."""
        port, self._port = self._port, None
        self._needs_setup = True
        if port is not None:
            try:
                port.close()
            except (serial.SerialException, OSError):
                pass

    def __enter__(self) -> Modem:
        self.open()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    @property
    def ready(self) -> bool:
        """Port open and modem set up."""
        return self._port is not None and not self._needs_setup

    # -- the public operations ------------------------------------------------------------------

    def stored_messages(self) -> list[ReceivedSms]:
        """Every received message on the store (``AT+CMGL="ALL"``), oldest index first."""
        response = self.command('AT+CMGL="ALL"', self.config.list_timeout_s)
        self._relist = False
        self._last_list = self.clock()
        messages = [
            dataclasses.replace(m, storage=self.config.storage)
            for m in response.messages
            if m.received
        ]
        listed = {m.index for m in messages}
        self._pending = [i for i in self._pending if i not in listed]
        return sorted(messages, key=lambda m: m.index or 0)

    def read(self, index: int) -> ReceivedSms | None:
        """The message at ``index`` (``AT+CMGR``), or None if the slot is empty."""
        try:
            response = self.command(f"AT+CMGR={int(index)}")
        except CommandError as exc:
            if exc.code == 321:  # invalid memory index: empty slot on some modems
                return None
            raise
        if not response.messages:
            return None  # most modems answer a bare OK for an empty slot
        return dataclasses.replace(response.messages[0], index=index, storage=self.config.storage)

    def delete(self, index: int) -> None:
        """Delete the message at ``index``. Call only after the message is stored (module doc)."""
        self.command(f"AT+CMGD={int(index)}")
        self._pending = [i for i in self._pending if i != index]

    def send(self, number: str, text: str) -> int | None:
        """Send one SMS; return its message reference (None if the modem gave none with OK).

        1. Check the text: GSM-7 only, one SMS (160 septets), no Ctrl-Z/ESC bytes (``Ξ`` and the
           extension characters ``^{}\\[~]|€`` cannot be typed in text mode) → UnsendableText.
        2. ``AT+CMGS="<number>"``, wait for ``> `` (ESC and ModemTimeout if it does not come).
        3. The text as GSM-7 bytes, then Ctrl-Z; wait up to ``send_timeout_s`` for
           ``+CMGS: <mr>`` and OK. No answer → SendUnconfirmed (it may have gone).
        4. ``+CMS ERROR: n`` → CommandError, ``permanent`` per TS 27.005 (331/332: temporary).
        """
        if not NUMBER.match(number):
            raise ModemUsageError(f"not a phone number: {number!r}")
        data = _typeable(text)
        self._ensure_ready()
        command = f'AT+CMGS="{number}"'
        self._start(command)
        deadline = self.clock() + self.config.command_timeout_s
        response = self._wait(deadline, until_prompt=True)
        if response is None:  # the prompt came
            self._write(data + CTRL_Z)
            try:
                response = self._wait(self.clock() + self.config.send_timeout_s)
            except (ModemTimeout, ModemRestarted, PortError) as exc:
                # The text and Ctrl-Z went out: it may have been sent. The caller decides.
                raise SendUnconfirmed(f"{command} sent, no answer: {exc}") from None
        elif response.result.ok:  # OK without a prompt: not sent
            raise ModemError(f"{command}: OK without a '> ' prompt; nothing sent")
        _raise_for(response)
        for line in response.lines:
            if line.upper().startswith("+CMGS"):
                try:
                    return parse_cmgs(line)
                except AtParseError:
                    log.warning("unreadable +CMGS answer %r", line)
        return None

    def poll_events(self, timeout: float) -> ModemEvents:
        """Wait up to ``timeout`` s for +CMTI indications; recover the modem on the way.

        Returns at once when indices are pending (they may have come during other commands) or
        a re-list is due. Temporary trouble (no answer, port gone) is logged and retried with
        backoff inside the timeout; a permanent error (PinRequired …) is raised. A recovery
        under way can overrun ``timeout`` (at most ``reset_attempts`` × ``wake_attempts`` ×
        ``wake_timeout_s`` plus one set-up).
        """
        deadline = self.clock() + timeout
        while True:
            if self._due():
                break
            try:
                self._ensure_ready()
                if self._due():
                    break
                remaining = deadline - self.clock()
                if remaining <= 0:
                    break
                self._handle(self._pump())
            except ModemError as exc:
                if exc.permanent:
                    raise
                log.warning("modem: %s", exc)
                wait = min(self._retry_at, deadline) - self.clock()
                if wait > 0:
                    time.sleep(wait)
            if self.clock() >= deadline:
                break
        return self._take_events()

    def command(self, line: str, timeout: float | None = None) -> Response:
        """Run one AT command and return its answer; error results raise CommandError."""
        self._ensure_ready()
        return self._command(line, timeout)

    # -- set-up and recovery --------------------------------------------------------------------

    def _ensure_ready(self) -> None:
        if self.ready:
            return
        now = self.clock()
        if now < self._retry_at:
            raise ModemTimeout(f"modem not ready; next attempt in {self._retry_at - now:.1f} s")
        try:
            if self._port is None:
                self._open_port()
            self._recover()
        except ModemError as exc:
            if not exc.permanent:
                self._retry_at = self.clock() + self._backoff
                self._backoff = doubled(self._backoff, cap=self.config.reconnect_max_s)
            raise
        self._backoff = self.config.reconnect_delay_s
        self._retry_at = 0.0

    def _open_port(self) -> None:
        try:
            self._port = self.port_factory(self.config.url, self.config.baudrate)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise PortError(f"cannot open {self.config.url}: {exc}") from None
        self._reader = AtReader()
        self._needs_setup = True
        self.opens += 1
        log.info("modem port %s open", self.config.url)

    def _recover(self) -> None:
        """Wake the modem, drain late answers, and run the set-up; bounded attempts."""
        last: ModemError = ModemTimeout("no attempt made")
        for _attempt in range(self.config.reset_attempts):
            try:
                self._wake()
                self._drain(self.config.settle_s)
                self._setup()
            except (ModemTimeout, ModemRestarted) as exc:
                last = exc
                continue
            except CommandError as exc:
                # Just after power-up a modem refuses SMS commands (302, 500, 512 …) until
                # "SMS Ready": retry those. A missing or locked SIM needs a person.
                if exc.permanent and "SIM" in exc.meaning:
                    raise
                last = ModemError(f"set-up failed: {exc}")
                continue
            self._needs_setup = False
            self._relist = True
            self.resets += 1
            return
        raise last

    def _wake(self) -> None:
        for _attempt in range(self.config.wake_attempts):
            self._reader.cancel()
            try:
                self._transact("AT", self.config.wake_timeout_s)
                return  # any final result, even ERROR, means it listens
            except (ModemTimeout, ModemRestarted):
                continue
        self._reader.cancel()
        raise ModemTimeout(f"no answer to AT after {self.config.wake_attempts} attempts")

    def _drain(self, seconds: float) -> None:
        """Let late answers to abandoned commands arrive (as noise) until the line stays quiet
        for ``seconds`` (at most ``DRAIN_LIMIT`` times that): otherwise a late ``OK`` would be
        taken as the answer to the next command. URCs among them are still handled."""
        start = self.clock()
        quiet_until = start + seconds
        while self.clock() < min(quiet_until, start + DRAIN_LIMIT * seconds):
            events = self._pump()
            if events:
                self._handle(events)
                quiet_until = self.clock() + seconds

    def _setup(self) -> None:
        """The set-up of docs/sms.md ('The GSM modem'), in that order."""
        self._command("ATE0")
        self._command("AT+CMEE=1")
        answer = self._command("AT+CPIN?")
        state = _field_of(answer, "+CPIN")
        if state.upper() != "READY":
            raise PinRequired(state or "no answer")
        self._command("AT+CMGF=1")
        self._command('AT+CSCS="GSM"')
        store = self.config.storage
        answer = self._command(f'AT+CPMS="{store}","{store}","{store}"')
        for line in answer.lines:
            if line.upper().startswith("+CPMS"):
                try:
                    usage = parse_cpms(line)[0]
                    self.store_usage = (usage.used, usage.total)
                except (AtParseError, IndexError):
                    log.warning("unreadable +CPMS answer %r", line)
        self._command("AT+CNMI=2,1,0,0,0")  # never 2,2: see the module doc
        try:
            self._command("AT+CSDH=1")  # text lengths in headers: exact multi-line texts
        except CommandError as exc:
            log.info("modem refuses AT+CSDH=1 (%s); reading texts without lengths", exc)

    # -- one command ----------------------------------------------------------------------------

    def _command(self, line: str, timeout: float | None = None) -> Response:
        response = self._transact(line, timeout or self.config.command_timeout_s)
        _raise_for(response)
        return response

    def _transact(self, line: str, timeout: float) -> Response:
        self._start(line)
        response = self._wait(self.clock() + timeout)
        assert response is not None
        return response

    def _start(self, line: str) -> None:
        self._reader.start(line)
        self._write(line.encode("latin-1") + b"\r")

    def _wait(self, deadline: float, until_prompt: bool = False) -> Response | None:
        """The answer to the command in flight (or None at its ``> `` prompt) by ``deadline``."""
        command = self._reader.command
        while True:
            remaining = deadline - self.clock()
            if remaining <= 0:
                self._abandon(until_prompt)
                raise ModemTimeout(f"no answer to {command} within the timeout")
            events = self._pump()
            for i, event in enumerate(events):
                if isinstance(event, Response) or (isinstance(event, Prompt) and until_prompt):
                    self._handle(events[i + 1 :])  # e.g. a +CMTI right after the OK
                    return event if isinstance(event, Response) else None
                if isinstance(event, Urc) and event.restart and self._reader.command:
                    self._reader.cancel()
                    self._handle(events[i:])
                    raise ModemRestarted(f"modem restarted ({event.text}) during {command}")
                self._handle([event])

    def _abandon(self, at_prompt: bool) -> None:
        """Give up on the command in flight; the modem gets a reset before the next one."""
        if at_prompt:
            try:
                self._write(ESC)  # leave text entry if the prompt was only late
            except PortError:
                pass
        self._reader.cancel()
        self._needs_setup = True

    # -- bytes ----------------------------------------------------------------------------------

    def _pump(self) -> list[Event]:
        """One read (blocking up to the port's READ_TIMEOUT_S) fed into the reader.

        The port's timeout is set once when it opens: setting it per call would reconfigure a
        real serial port each time. Deadlines are checked between reads.
        """
        port = self._port
        if port is None:
            raise PortError("port closed")
        try:
            data = port.read(1)
            while data and port.in_waiting:
                data += port.read(port.in_waiting)
        except (serial.SerialException, OSError) as exc:
            self._port_failed(exc)
        if not data:
            return []
        return self._reader.feed(data)

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
        log.warning("modem port %s failed: %s", self.config.url, exc)
        self._reader.cancel()
        self.close()
        self._relist = True
        raise PortError(f"port {self.config.url} failed: {exc}") from None

    # -- events ---------------------------------------------------------------------------------

    def _handle(self, events: list[Event]) -> None:
        """Side effects of events outside a command's answer: +CMTI, restarts, noise."""
        for event in events:
            if isinstance(event, Urc):
                if event.name == "+CMTI":
                    try:
                        _storage, index = parse_cmti(event.text)
                    except AtParseError as exc:
                        log.warning("%s", exc)
                        continue
                    if index not in self._pending:
                        self._pending.append(index)
                elif event.restart:
                    if not self._needs_setup:
                        log.warning("modem restarted (%s); set-up again", event.text)
                        self.restarts_seen += 1
                    self._needs_setup = True
                    self._relist = True
                elif event.name == "+CMT" and event.sms is not None:
                    # Only with CNMI 2,2, which we never set: the text is not on the SIM.
                    log.error("+CMT pushed a message that is not stored: %s", event.sms)
                else:
                    log.debug("URC %s", event.text)
            elif isinstance(event, Noise):
                self.noise_lines += 1
                log.info("modem noise (%s): %r", event.reason, event.text)
            elif isinstance(event, Echo | Prompt):
                pass
            else:  # a Response with nothing waiting for it cannot happen: the reader ties them
                log.warning("unexpected %r", event)

    def _due(self) -> bool:
        if self._pending:
            return True
        if not self.ready:
            return False
        interval = self.config.relist_interval_s
        if interval is not None and self.clock() - self._last_list >= interval:
            self._relist = True
        return self._relist

    def _take_events(self) -> ModemEvents:
        relist = self._relist and self.ready
        events = ModemEvents(tuple(self._pending), relist)
        self._pending = []
        if relist:
            self._relist = False
            self._last_list = self.clock()
        return events


def _field_of(response: Response, name: str) -> str:
    for line in response.lines:
        head, _colon, rest = line.partition(":")
        if head.strip().upper() == name:
            return rest.strip().strip('"')
    return ""


def _raise_for(response: Response) -> None:
    result = response.result
    if not result.ok:
        raise CommandError(
            response.command, result.kind, result.code, result.meaning, not result.temporary
        )


def _typeable(text: str) -> bytes:
    try:
        data = gsm7.encode(text)
    except gsm7.Gsm7Error as exc:
        raise UnsendableText(f"{exc}; spell replies with sms.gsm7.to_gsm7") from None
    bad = sorted({ch for ch in text if set(gsm7.encode(ch)) & _UNTYPEABLE})
    if bad:
        raise UnsendableText(f"{''.join(bad)!r} cannot be typed in text mode (Ctrl-Z/ESC bytes)")
    if len(data) > SMS_SEPTETS:
        raise UnsendableText(f"{len(data)} septets: one SMS holds {SMS_SEPTETS}")
    return data


def receive_all(
    modem: Modem,
    store: Callable[[ReceivedSms], None],
    events: ModemEvents | None = None,
) -> int:
    """Read every stored or newly indicated message, ``store`` it, and only then delete it.

    1. With ``events`` None or ``events.relist``: list everything stored (``AT+CMGL``).
    2. Read each index announced by +CMTI and not listed (``AT+CMGR``).
    3. For each received message: ``store(message)``, which must COMMIT before returning and
       must be idempotent on ``message.key`` (a crash between commit and delete shows the
       message again next time); then ``modem.delete(message.index)``.

    A message whose ``store`` raises stays on the SIM (logged; tried again at the next
    re-list); modem errors propagate. Returns how many messages were stored and deleted.
    """
    messages: list[ReceivedSms] = []
    if events is None or events.relist:
        messages = modem.stored_messages()
    listed = {m.index for m in messages}
    for index in events.indices if events else ():
        if index not in listed:
            message = modem.read(index)
            if message is not None:
                messages.append(message)
                listed.add(index)
    done = 0
    for message in messages:
        if not message.received or message.index is None:
            continue
        try:
            store(message)
        except Exception:  # noqa: BLE001 - one bad message must not block the others
            log.exception("storing SMS at %s failed; it stays on the SIM", message.index)
            continue
        modem.delete(message.index)
        done += 1
    return done
