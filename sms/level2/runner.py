"""The only Level 2 module that does I/O: opens ports and moves bytes to and from the pure layers.

References: §2 (115200 baud 8N1, no flow control) and §16 (inter-byte timeout for half frames)
of docs/level2.md; ports open through ``serial.serial_for_url`` (real devices,
``socket://`` and ``loop://``; the read loop only moves bytes into the decoder).

* :func:`open_port` opens a pyserial URL or device, or ``pty`` (a new pseudo-terminal pair whose
  other end a peer opens by name, for demos and tests).
* :class:`PayloadRunner` runs a :class:`~.payload.PayloadMachine` on a port and survives the port
  disappearing: it closes, waits and reopens until stopped.
* :class:`SerialLink` is the :class:`~.simulator.Link` the C&C simulator uses over a port.
"""

from __future__ import annotations

import fcntl
import logging
import os
import select
import sys
import termios
import threading
import time
import tty
from collections.abc import Callable
from typing import Any

import serial

from .bodies import summarize
from .codec import Frame
from .errors import FrameError, Level2Error
from .framing import INTERBYTE_TIMEOUT_S, Decoder
from .payload import Ignored, Notification, PayloadMachine

log = logging.getLogger(__name__)

BAUDRATE = 115_200  # §2
READ_TIMEOUT_S = 0.05  # how long one read blocks; bounds how fast a stop request is seen
RECONNECT_DELAY_S = 1.0  # between attempts to reopen a port that went away


class PtyPort:
    """The master end of a new pseudo-terminal pair, with the small pyserial API we use.

    ``name`` is the slave device path (``/dev/pts/N``) for the peer to open. We keep a slave fd
    open ourselves so reads do not fail with EIO while the peer is not (yet) connected.
    """

    def __init__(self, timeout: float = READ_TIMEOUT_S) -> None:
        self.timeout = timeout
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo or line editing before the peer configures it
        self.name = os.ttyname(self._slave)
        self.is_open = True

    @property
    def in_waiting(self) -> int:
        """Bytes readable now (FIONREAD, as pyserial's PosixSerial does)."""
        count = fcntl.ioctl(self._master, termios.FIONREAD, b"\0\0\0\0")
        return int.from_bytes(count, sys.byteorder)

    def read(self, size: int = 1) -> bytes:
        ready, _, _ = select.select([self._master], [], [], self.timeout)
        if not ready:
            return b""
        return os.read(self._master, max(size, 1))

    def write(self, data: bytes) -> int:
        view = memoryview(data)
        while view:
            written = os.write(self._master, view)
            view = view[written:]
        return len(data)

    def flush(self) -> None:
        pass

    def fileno(self) -> int:
        return self._master

    def close(self) -> None:
        if self.is_open:
            self.is_open = False
            os.close(self._master)
            os.close(self._slave)


def open_port(url: str, timeout: float = READ_TIMEOUT_S) -> Any:
    """Open ``url`` (device path, ``socket://``, ``loop://``, any pyserial URL, or ``pty``)."""
    if url == "pty":
        return PtyPort(timeout)
    return serial.serial_for_url(url, baudrate=BAUDRATE, timeout=timeout)


def _read_some(port: Any) -> bytes:
    """Block up to the port's timeout for one byte, then take whatever else has arrived."""
    data = port.read(1)
    if data:
        waiting = port.in_waiting
        if waiting:
            data += port.read(waiting)
    return data


class PayloadRunner:
    """Serve a payload machine on a port until :meth:`stop`; reopen the port when it fails."""

    def __init__(
        self,
        url: str,
        machine: PayloadMachine,
        *,
        reconnect_delay_s: float = RECONNECT_DELAY_S,
        interbyte_timeout_s: float = INTERBYTE_TIMEOUT_S,
        trace: Callable[[str], None] | None = None,
        on_notification: Callable[[Notification], None] | None = None,
        port_factory: Callable[[str], Any] = open_port,
    ) -> None:
        self.url = url
        self.machine = machine
        self.reconnect_delay_s = reconnect_delay_s
        self.interbyte_timeout_s = interbyte_timeout_s
        self.trace = trace or (lambda line: log.debug("%s", line))
        self.on_notification = on_notification
        self.port_factory = port_factory
        self._stop = threading.Event()
        self.connected = threading.Event()
        self.opens = 0
        self.port_failures = 0
        self.frames_in = 0
        self.frames_out = 0
        self.frame_errors = 0
        self.dropped_bytes = 0

    def stop(self) -> None:
        self._stop.set()

    def run(self) -> None:
        """Open, serve, and on any port failure close, wait and reopen, until stopped."""
        while not self._stop.is_set():
            try:
                port = self.port_factory(self.url)
            except (serial.SerialException, OSError, ValueError) as exc:
                self.port_failures += 1
                self.trace(f"cannot open {self.url}: {exc}; retrying")
                self._stop.wait(self.reconnect_delay_s)
                continue
            self.opens += 1
            self.connected.set()
            try:
                self.serve(port)
            except (serial.SerialException, OSError) as exc:
                # The device went away (USB unplugged, socket peer gone): reopen it.
                self.port_failures += 1
                self.trace(f"port {self.url} failed: {exc}; reopening")
            finally:
                self.connected.clear()
                try:
                    port.close()
                except (serial.SerialException, OSError):
                    pass
            self._stop.wait(self.reconnect_delay_s)

    def serve(self, port: Any) -> None:
        """Move bytes from ``port`` into a fresh decoder and the machine's replies back out."""
        decoder = Decoder(self.interbyte_timeout_s)
        while not self._stop.is_set():
            data = _read_some(port)
            decoder.feed(data, time.monotonic())
            for item in decoder.frames():
                if isinstance(item, FrameError):
                    self.frame_errors += 1
                    self.trace(f"dropped: {item}")
                    continue
                self.frames_in += 1
                try:
                    replies = self.machine.handle(item)
                except Level2Error as exc:
                    # e.g. a configuration the protocol cannot express: log it, keep serving
                    self.trace(f"cannot answer {summarize(item)}: {exc}")
                    continue
                if replies:
                    # Write before tracing: the C&C times the reply (§2: 4–17 ms on the real PIB).
                    port.write(b"".join(bytes(r) for r in replies))
                    self.frames_out += len(replies)
                self.trace(f"C&C -> {summarize(item)}")
                for reply in replies:
                    self.trace(f"PAY -> {summarize(reply)}")
            self.dropped_bytes = decoder.dropped_bytes
            for note in self.machine.notifications():
                if self.on_notification:
                    self.on_notification(note)
                elif not isinstance(note, Ignored):
                    self.trace(f"event: {note}")


class SerialLink:
    """The simulator's link over an open port (see :class:`~.simulator.Link`)."""

    def __init__(self, port: Any, interbyte_timeout_s: float = INTERBYTE_TIMEOUT_S) -> None:
        self.port = port
        self.decoder = Decoder(interbyte_timeout_s)
        self.errors: list[FrameError] = []

    def send(self, data: bytes, *, split: bool = False) -> None:
        if split:
            for i in range(len(data)):
                self.port.write(data[i : i + 1])
                self.port.flush()
        else:
            self.port.write(data)
            self.port.flush()

    def receive(self, timeout_s: float) -> Frame | None:
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                frame = self.decoder.next_frame()
            except FrameError as exc:
                self.errors.append(exc)
                continue
            if frame is not None:
                return frame
            if time.monotonic() >= deadline:
                return None
            self.decoder.feed(_read_some(self.port), time.monotonic())
