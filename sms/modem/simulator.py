"""A simulated GSM modem speaking the text-mode SMS AT dialogue, for tests and demos.

References: docs/sms.md, 'The GSM modem' (the dialogue and its quirks); 3GPP TS 27.005.

:class:`SimulatedModem` is the modem itself and does no I/O: bytes in (:meth:`receive`), bytes
out (:meth:`take_output`, each chunk with the time it is due, so slow answers need no sleeping
thread). It holds a message store (``"SM"``, limited: a full store rejects incoming messages,
recorded in ``rejected``, and ``AT+CMGW`` answers ``+CMS ERROR: 322``), echoes until ``ATE0``
as a modem does after power-up, and records every SMS sent. Faults switched on from tests or the CLI
(:class:`Faults`): slow answers, ``+CMS ERROR: n`` on the next send or read, garbage lines,
unsolicited lines in the middle of a reply, a reset (power-up burst, echo on, PDU mode, store
kept) and a deaf period.

:class:`ModemServer` serves one simulated modem over a pseudo-terminal (the driver opens the
slave device) or a TCP socket (``socket://127.0.0.1:PORT``), in a thread that stops by itself.
"""

from __future__ import annotations

import logging
import os
import random
import re
import select
import socket
import threading
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime

from sms import gsm7

from .error_codes import CMS_ERRORS

log = logging.getLogger(__name__)

CAPACITY = 20  # a typical SIM holds 20–50 SMS
SMSC = "+61418706700"  # the service centre shown by AT+CSDH=1 headers (any plausible number)
POWER_UP_BURST = ("RDY", "+CFUN: 1", "+CPIN: READY", "SMS Ready")  # Quectel/SIMCom order
IDENTITY = ("Shoreside", "ModemSim", "Revision: 1.0")
_CMGL_FILTERS = {
    "ALL": None,
    "REC UNREAD": {"REC UNREAD"},
    "REC READ": {"REC READ"},
    "STO UNSENT": {"STO UNSENT"},
    "STO SENT": {"STO SENT"},
}
_DELETE_FLAGS = {  # AT+CMGD=<index>,<delflag> (TS 27.005 §3.5.4)
    1: {"REC READ"},
    2: {"REC READ", "STO SENT"},
    3: {"REC READ", "STO SENT", "STO UNSENT"},
    4: {"REC READ", "STO SENT", "STO UNSENT", "REC UNREAD"},
}


@dataclass
class StoredMessage:
    status: str
    number: str
    text: str
    timestamp: datetime


@dataclass(frozen=True)
class SentSms:
    number: str
    text: str
    reference: int


@dataclass
class Faults:
    """Misbehaviour, switched on and off at any time (tests hold a reference)."""

    delay_s: float = 0.0  # every answer comes this late
    send_delay_s: float = 0.0  # and +CMGS this much later again (the network round trip)
    send_error: int | None = None  # +CMS ERROR for the next AT+CMGS (one shot)
    read_error: int | None = None  # +CMS ERROR for the next AT+CMGR/AT+CMGL (one shot)
    garbage: bool = False  # a line of junk before every answer
    urc_mid_reply: bool = False  # URCs (and +CMTI held back) between lines of the next answers
    sticky_errors: bool = False  # send_error/read_error stay on until cleared


@dataclass
class SimulatedModem:
    """The modem's state and AT interpreter. Thread-safe: tests call it while a server runs."""

    capacity: int = CAPACITY
    storage: str = "SM"
    pin_ready: bool = True
    seed: int = 0
    clock: Callable[[], float] = time.monotonic
    faults: Faults = field(default_factory=Faults)

    def __post_init__(self) -> None:
        self.store: dict[int, StoredMessage] = {}
        self.sent: list[SentSms] = []
        self.rejected: list[tuple[str, str]] = []  # messages refused because the store was full
        self.commands: list[str] = []  # every command line received, for tests
        self._rng = random.Random(self.seed)
        self._lock = threading.RLock()
        self._out: list[tuple[float, bytes]] = []
        self._held_urcs: list[str] = []
        self._deaf_until = 0.0
        self._sms_ready_at = 0.0
        self._last_due = 0.0  # when the last answer byte queued is due
        self._reference = 0
        self._power_up_state()

    def _power_up_state(self) -> None:
        self.echo = True
        self.text_mode = False
        self.cmee = 0
        self.csdh = 0
        self.cnmi_mt = 0
        self.charset = "IRA"
        self._line = bytearray()
        self._compose_to: str | None = None
        self._compose_write = False  # composing for AT+CMGW (store) rather than AT+CMGS
        self._compose = bytearray()

    # -- the outside world ----------------------------------------------------------------------

    def inject(self, number: str, text: str, when: datetime | None = None) -> int | None:
        """An SMS arrives: store it and announce ``+CMTI`` (with AT+CNMI=2,1). Its index, or
        None when the store is full (the network keeps it; here it is recorded in ``rejected``)."""
        with self._lock:
            stamp = (when or datetime.now(UTC)).replace(microsecond=0)
            if self.cnmi_mt == 2:  # pushed, not stored: what CNMI 2,2 does
                self._urc(f"+CMT: {self._deliver_fields(number, stamp, text)}", text)
                return None
            free = [i for i in range(1, self.capacity + 1) if i not in self.store]
            if not free:
                self.rejected.append((number, text))
                return None
            index = free[0]
            self.store[index] = StoredMessage("REC UNREAD", number, text, stamp)
            if self.cnmi_mt == 1:
                line = f'+CMTI: "{self.storage}",{index}'
                if self.faults.urc_mid_reply:
                    self._held_urcs.append(line)
                else:
                    self._urc(line)
            return index

    def reset(self, boot_s: float = 0.0, sms_ready_s: float = 0.0) -> None:
        """Power-cycle: forget the settings (echo on, PDU mode, no indications), keep the SIM
        store, stay deaf for ``boot_s`` and then print the power-up burst. For ``sms_ready_s``
        more, SMS commands answer ``+CMS ERROR: 302`` and ``SMS Ready`` comes last, as on
        SIMCom/Quectel modules whose SMS stack starts after the rest."""
        with self._lock:
            self._power_up_state()
            self._out.clear()
            self._held_urcs.clear()
            self._last_due = 0.0
            now = self.clock()
            self._deaf_until = now + boot_s
            self._sms_ready_at = now + boot_s + sms_ready_s
            *first, last = POWER_UP_BURST
            self._out.append((now + boot_s, b"".join(f"\r\n{x}\r\n".encode() for x in first)))
            self._out.append((self._sms_ready_at, f"\r\n{last}\r\n".encode()))

    def go_deaf(self, seconds: float) -> None:
        """Stop answering (and drop input) for ``seconds``."""
        with self._lock:
            self._deaf_until = self.clock() + seconds

    def garbage(self, size: int = 32) -> None:
        """Emit ``size`` random bytes now (no CR LF among them), as a noisy line would."""
        with self._lock:
            junk = bytes(self._rng.choice(range(0x80, 0x100)) for _ in range(size))
            self._out.append((self.clock(), junk + b"\r\n"))

    def take_output(self) -> bytes:
        """Bytes due now, in the order they were queued."""
        with self._lock:
            now = self.clock()
            if now < self._deaf_until:
                return b""  # a hung modem prints nothing; what it owes comes out later
            ready = b"".join(data for due, data in self._out if due <= now)
            self._out = [(due, data) for due, data in self._out if due > now]
            return ready

    def receive(self, data: bytes) -> None:
        """Bytes typed by the driver."""
        with self._lock:
            if self.clock() < self._deaf_until:
                return
            for byte in data:
                self._byte(byte)

    # -- the interpreter ------------------------------------------------------------------------

    def _byte(self, byte: int) -> None:
        if self._compose_to is not None:
            self._compose_byte(byte)
            return
        if self.echo:
            self._emit(bytes((byte,)), delay=False)
        if byte == 0x0D:
            line = self._line.decode("latin-1").strip()
            self._line.clear()
            if line:
                self._command(line)
        elif byte != 0x0A:
            self._line.append(byte)

    def _compose_byte(self, byte: int) -> None:
        if self.echo:
            self._emit(bytes((byte,)), delay=False)
        if byte == 0x1A:  # Ctrl-Z: send
            self._finish_send()
        elif byte == 0x1B:  # ESC: abandon
            self._compose_to = None
            self._compose_write = False
            self._compose.clear()
            self._answer([], "OK")
        else:
            self._compose.append(byte)
            if byte == 0x0D:  # Telit and others prompt again after each CR
                self._emit(b"\r\n> ", delay=False)

    def _command(self, line: str) -> None:
        self.commands.append(line)
        upper = line.upper()
        if not upper.startswith("AT"):
            self._answer([], "ERROR")
            return
        body = line[2:]
        handler = self._dispatch(body)
        if handler is None:
            self._answer([], "ERROR")
            return
        handler()

    def _dispatch(self, body: str) -> Callable[[], None] | None:
        upper = body.upper()
        simple: dict[str, Callable[[], None]] = {
            "": lambda: self._answer([], "OK"),
            "E0": lambda: self._set("echo", False),
            "E1": lambda: self._set("echo", True),
            "I": lambda: self._answer(list(IDENTITY), "OK"),
            "+CPIN?": self._cpin,
            "+CSQ": lambda: self._answer(["+CSQ: 21,99"], "OK"),
            "+CREG?": lambda: self._answer(["+CREG: 0,1"], "OK"),
            "+CMGF?": lambda: self._answer([f"+CMGF: {int(self.text_mode)}"], "OK"),
            "+CSCS?": lambda: self._answer([f'+CSCS: "{self.charset}"'], "OK"),
            "+CNMI?": lambda: self._answer([f"+CNMI: 2,{self.cnmi_mt},0,0,0"], "OK"),
            "+CPMS?": lambda: self._answer([self._cpms(named=True)], "OK"),
        }
        if upper in simple:
            return simple[upper]
        patterns: list[tuple[str, Callable[[re.Match[str]], None]]] = [
            (r"\+CMEE=([012])", lambda m: self._set("cmee", int(m.group(1)))),
            (r"\+CMGF=([01])", lambda m: self._set("text_mode", m.group(1) == "1")),
            (r"\+CSDH=([01])", lambda m: self._set("csdh", int(m.group(1)))),
            (r'\+CSCS="(GSM|IRA|UCS2)"', lambda m: self._set("charset", m.group(1))),
            (r'\+CPMS="(\w+)"(?:,"(\w+)")?(?:,"(\w+)")?', self._cpms_set),
            (r"\+CNMI=(\d)(?:,(\d))?(?:,\d)*", self._cnmi),
            (r'\+CMGL(?:="([A-Z ]+)")?', self._cmgl),
            (r"\+CMGR=(\d+)", self._cmgr),
            (r"\+CMGD=(\d+)(?:,(\d))?", self._cmgd),
            (r'\+CMGS="(\+?[0-9]{1,20})"(?:,\d+)?', self._cmgs),
            (r'\+CMGW="(\+?[0-9]{1,20})"(?:,\d+)?', self._cmgw),
        ]
        for pattern, action in patterns:
            match = re.fullmatch(pattern, body, re.IGNORECASE)
            if match:
                return lambda action=action, match=match: action(match)
        return None

    def _set(self, name: str, value: object) -> None:
        setattr(self, name, value)
        self._answer([], "OK")

    def _cpin(self) -> None:
        self._answer(["+CPIN: READY" if self.pin_ready else "+CPIN: SIM PIN"], "OK")

    def _cpms(self, named: bool) -> str:
        used, total = len(self.store), self.capacity
        if named:
            return "+CPMS: " + ",".join([f'"{self.storage}",{used},{total}'] * 3)
        return "+CPMS: " + ",".join([f"{used},{total}"] * 3)

    def _cpms_set(self, match: re.Match[str]) -> None:
        if self.clock() < self._sms_ready_at:
            self._error(302)  # the SMS stack is not up yet
            return
        if any(m and m.upper() != self.storage for m in match.groups()):
            self._error(302)  # only the SIM store is simulated
            return
        self._answer([self._cpms(named=False)], "OK")

    def _cnmi(self, match: re.Match[str]) -> None:
        self.cnmi_mt = int(match.group(2) or 0)
        self._answer([], "OK")

    def _cmgl(self, match: re.Match[str]) -> None:
        if not self._text_ready() or self._read_fault():
            return
        wanted = (match.group(1) or "REC UNREAD").upper()
        if wanted not in _CMGL_FILTERS:
            self._error(305)
            return
        states = _CMGL_FILTERS[wanted]
        units = []
        for index in sorted(self.store):
            message = self.store[index]
            if states is None or message.status in states:
                units.append(self._listing(index, message))
                if message.status == "REC UNREAD":
                    message.status = "REC READ"
        self._answer_units(units, "OK")

    def _cmgr(self, match: re.Match[str]) -> None:
        if not self._text_ready() or self._read_fault():
            return
        index = int(match.group(1))
        if not 1 <= index <= self.capacity:
            self._error(321)
            return
        message = self.store.get(index)
        if message is None:
            self._answer([], "OK")  # Quectel/SIMCom: an empty slot answers a bare OK
            return
        header = f'+CMGR: "{message.status}",' + self._deliver_fields(
            message.number,
            message.timestamp,
            message.text,
            full=True,
            outgoing=message.status.startswith("STO"),
        )
        if message.status == "REC UNREAD":
            message.status = "REC READ"
        self._answer_units([[header.encode("latin-1"), self._body(message.text)]], "OK")

    def _cmgd(self, match: re.Match[str]) -> None:
        index, flag = int(match.group(1)), int(match.group(2) or 0)
        if flag:
            states = _DELETE_FLAGS.get(flag)
            if states is None:
                self._error(305)
                return
            for i in [i for i, m in self.store.items() if m.status in states]:
                del self.store[i]
        elif not 1 <= index <= self.capacity:
            self._error(321)
            return
        else:
            self.store.pop(index, None)
        self._answer([], "OK")

    def _cmgs(self, match: re.Match[str]) -> None:
        if not self._text_ready():
            return
        self._compose_to = match.group(1)
        self._compose.clear()
        self._emit(b"\r\n> ")

    def _cmgw(self, match: re.Match[str]) -> None:
        """Write a message to the store (the command that meets a full store: 322)."""
        self._cmgs(match)
        self._compose_write = True

    def _finish_send(self) -> None:
        number, data = self._compose_to or "", bytes(self._compose)
        self._compose_to = None
        self._compose.clear()
        text = gsm7.decode(data) if self.charset == "GSM" else data.decode("latin-1")
        if self._compose_write:
            self._compose_write = False
            free = [i for i in range(1, self.capacity + 1) if i not in self.store]
            if not free:
                self._error(322)  # memory full
                return
            now = datetime.now(UTC).replace(microsecond=0)
            self.store[free[0]] = StoredMessage("STO UNSENT", number, text, now)
            self._answer([f"+CMGW: {free[0]}"], "OK")
            return
        code = self.faults.send_error
        if code is not None:
            if not self.faults.sticky_errors:
                self.faults.send_error = None
            self._error(code)
            return
        self._reference = (self._reference + 1) % 256
        self.sent.append(SentSms(number, text, self._reference))
        self._answer([f"+CMGS: {self._reference}"], "OK", extra_delay=self.faults.send_delay_s)

    # -- helpers --------------------------------------------------------------------------------

    def _text_ready(self) -> bool:
        if self.clock() < self._sms_ready_at or not self.text_mode:
            self._error(302)  # a real modem in PDU mode would list PDUs; refuse instead
            return False
        return True

    def _read_fault(self) -> bool:
        code = self.faults.read_error
        if code is None:
            return False
        if not self.faults.sticky_errors:
            self.faults.read_error = None
        self._error(code)
        return True

    def _deliver_fields(
        self, number: str, when: datetime, text: str, full: bool = False, outgoing: bool = False
    ) -> str:
        # TS 27.005 §3.4.3/§4.1: a received message shows <oa>,<alpha>,<scts>; one we stored
        # to send (STO …) shows <da>,<alpha> and no time stamp.
        fields = f'"{number}",' if outgoing else f'"{number}",,"{scts(when)}"'
        if self.csdh:
            toa = 145 if number.startswith("+") else 129
            length = len(self._body(text))
            extra = f',{toa},4,0,0,"{SMSC}",145,{length}' if full else f",{toa},{length}"
            fields += extra
        return fields

    def _listing(self, index: int, message: StoredMessage) -> list[bytes]:
        header = f'+CMGL: {index},"{message.status}",' + self._deliver_fields(
            message.number,
            message.timestamp,
            message.text,
            outgoing=message.status.startswith("STO"),
        )
        return [header.encode("latin-1"), self._body(message.text)]

    def _body(self, text: str) -> bytes:
        if self.charset == "GSM":
            return gsm7.encode(gsm7.to_gsm7(text))
        return text.encode("latin-1", "replace")

    def _error(self, code: int) -> None:
        if self.cmee == 0:
            self._answer([], "ERROR")
        elif self.cmee == 1:
            self._answer([], f"+CMS ERROR: {code}")
        else:
            meaning = CMS_ERRORS.get(code, ("unknown error", True))[0]
            self._answer([], f"+CMS ERROR: {meaning}")

    def _answer(self, lines: list[str], final: str, extra_delay: float = 0.0) -> None:
        self._answer_units([[line.encode("latin-1")] for line in lines], final, extra_delay)

    def _answer_units(self, units: list[list[bytes]], final: str, extra_delay: float = 0.0) -> None:
        """Information units (a header and its text stay together), then the final result.

        With ``faults.urc_mid_reply`` held-back +CMTI lines (or a +CREG) go between units and
        before the final result; with ``faults.garbage`` a junk line goes first.
        """
        out = bytearray()
        if self.faults.garbage:
            junk = bytes(self._rng.choice(range(0x80, 0x100)) for _ in range(12))
            out += b"\r\n" + junk + b"\r\n"
        for position, unit in enumerate(units):
            for number, line in enumerate(unit):  # a text follows its header directly
                out += (b"" if number else b"\r\n") + line + b"\r\n"
            if self.faults.urc_mid_reply and position == 0:
                out += self._mid_reply_urcs()
        if self.faults.urc_mid_reply and not units:
            out += self._mid_reply_urcs()
        out += f"\r\n{final}\r\n".encode("latin-1")
        self._emit(bytes(out), extra_delay=extra_delay)

    def _mid_reply_urcs(self) -> bytes:
        lines = self._held_urcs or ["+CREG: 1"]
        self._held_urcs = []
        return b"".join(f"\r\n{line}\r\n".encode("latin-1") for line in lines)

    def _urc(self, line: str, text: str | None = None) -> None:
        data = f"\r\n{line}\r\n".encode("latin-1")
        if text is not None:
            data += self._body(text) + b"\r\n"
        self._out.append((self.clock(), data))

    def _emit(self, data: bytes, delay: bool = True, extra_delay: float = 0.0) -> None:
        """Queue answer bytes; an answer never overtakes an earlier one (URCs may)."""
        due = self.clock() + (self.faults.delay_s if delay else 0.0) + extra_delay
        due = max(due, self._last_due)
        self._last_due = due
        self._out.append((due, data))


def scts(when: datetime) -> str:
    """An aware datetime as ``yy/MM/dd,hh:mm:ss±zz`` (zone in quarter hours)."""
    offset = when.utcoffset()
    quarters = int(offset.total_seconds() // 900) if offset is not None else 0
    sign = "-" if quarters < 0 else "+"
    return when.strftime("%y/%m/%d,%H:%M:%S") + f"{sign}{abs(quarters):02d}"


class ModemServer:
    """Serve a :class:`SimulatedModem` on a pty (``where="pty"``) or TCP (``"tcp:PORT"``).

    ``url`` is what the driver opens: the pty's slave device, or ``socket://127.0.0.1:PORT``.
    TCP takes one client at a time and accepts the next when it goes (the modem keeps its
    state, as a USB modem does when its port is reopened). :meth:`drop_client` cuts the
    current connection, as an unplugged cable would.
    """

    POLL_S = 0.01

    def __init__(self, modem: SimulatedModem, where: str = "pty") -> None:
        self.modem = modem
        self._stop = threading.Event()
        self._client: socket.socket | None = None
        self._listener: socket.socket | None = None
        self._master = self._slave = -1
        if where == "pty":
            self._master, self._slave = os.openpty()
            tty.setraw(self._slave)
            self.url = os.ttyname(self._slave)
        elif where.startswith("tcp:"):
            self._listener = socket.create_server(("127.0.0.1", int(where[4:])))
            self.url = f"socket://127.0.0.1:{self._listener.getsockname()[1]}"
        else:
            raise ValueError(f"where must be 'pty' or 'tcp:PORT', not {where!r}")
        self._thread = threading.Thread(target=self._run, name="modem-sim", daemon=True)

    def start(self) -> ModemServer:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5)
        for sock in (self._client, self._listener):
            if sock is not None:
                sock.close()
        for fd in (self._master, self._slave):
            if fd >= 0:
                os.close(fd)
        self._master = self._slave = -1

    def __enter__(self) -> ModemServer:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()

    def drop_client(self) -> None:
        """Close the TCP connection under the driver's feet."""
        client, self._client = self._client, None
        if client is not None:
            client.close()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                if self._listener is not None:
                    self._serve_tcp()
                else:
                    self._serve_fd(self._master)
            except OSError as exc:  # a client vanished mid-write: wait for the next
                log.info("modem simulator: %s", exc)
                self.drop_client()

    def _serve_fd(self, fd: int) -> None:
        readable, _, _ = select.select([fd], [], [], self.POLL_S)
        if readable:
            self.modem.receive(os.read(fd, 4096))
        out = self.modem.take_output()
        if out:
            os.write(fd, out)

    def _serve_tcp(self) -> None:
        assert self._listener is not None
        if self._client is None:
            readable, _, _ = select.select([self._listener], [], [], self.POLL_S)
            if readable:
                self._client, _ = self._listener.accept()
            return
        client = self._client
        readable, _, _ = select.select([client], [], [], self.POLL_S)
        if readable:
            data = client.recv(4096)
            if not data:
                self.drop_client()
                return
            self.modem.receive(data)
        out = self.modem.take_output()
        if out and self._client is client:
            client.sendall(out)
