"""The sensor manager's I/O: subscribe to the payload board's UDP data servers, decode what they
send, keep the latest readings.

References: docs/wave-glider.md#sensors (a data server is subscribed to by sending a packet to the
relevant port number on the payload board. The payload board will send data using UDP to
whichever IP address last contacted it; one model of the glider's state; the sensor
manager's readings answer the C&C's status requests); §8.4 of docs/level2.md (the status
block). Decoding is ``sms.bridge.records`` (pure); this module owns the sockets. No Django.

* :class:`LatestReadings`: the newest value of each reading (for fixes and, later, ``#STATUS``)
  and the machine's :class:`SensorState` (for the Level 2 status replies), thread-safe; a
  reading older than ``max_age_s`` is forgotten rather than reported as current.
* :class:`SensorSubscriber`: one UDP socket per record type (the record type is known by the
  socket, whatever source port the board sends from); sends the subscription packet at start,
  every ``resubscribe_s`` (another client may have taken the board's "last contacted" address),
  and after ``silence_s`` with no data (the board rebooted and forgot us). Garbage and short
  datagrams are logged, counted and dropped. ``python -m sms.bridge.sensors --host H`` watches.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import selectors
import socket
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from sms.level2.payload import SensorState

from .records import RecordError, RecordLayout, RecordTable

log = logging.getLogger(__name__)

RESUBSCRIBE_S = 60.0
SILENCE_S = 10.0
MAX_AGE_S = 120.0  # a reading this old is no longer the glider's state
MAX_DATAGRAM = 65_535
# SensorState's reading fields (alarms is not a sensor reading).
STATE_FIELDS = frozenset(f.name for f in dataclasses.fields(SensorState)) - {"alarms"}


class LatestReadings:
    """The newest value of each reading and when it came; updates the machine's SensorState."""

    def __init__(
        self,
        state: SensorState | None = None,
        *,
        max_age_s: float = MAX_AGE_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.state = state if state is not None else SensorState()
        self.max_age_s = max_age_s
        self.clock = clock
        self._lock = threading.Lock()
        self._values: dict[str, tuple[float, float]] = {}

    def update(self, readings: Mapping[str, float]) -> None:
        now = self.clock()
        with self._lock:
            for name, value in readings.items():
                self._values[name] = (value, now)
                if name in STATE_FIELDS:
                    setattr(self.state, name, value)  # one attribute store: atomic for readers

    def snapshot(self) -> dict[str, float]:
        """The readings not older than ``max_age_s`` (stale ones are forgotten now)."""
        self.expire()
        with self._lock:
            return {name: value for name, (value, _at) in self._values.items()}

    def expire(self) -> list[str]:
        """Forget readings older than ``max_age_s``; the status block then sends 0 (unknown)."""
        cutoff = self.clock() - self.max_age_s
        with self._lock:
            stale = [name for name, (_v, at) in self._values.items() if at < cutoff]
            for name in stale:
                del self._values[name]
                if name in STATE_FIELDS:
                    setattr(self.state, name, None)
        return stale


@dataclass
class SensorStats:
    subscriptions: int = 0
    send_errors: int = 0
    datagrams: int = 0
    records: int = 0
    foreign: int = 0  # datagrams from another host than the board
    dropped: Counter = field(default_factory=Counter)  # reason → datagrams not decoded
    readings_dropped: Counter = field(default_factory=Counter)  # reading → implausible values


@dataclass
class _Stream:
    record: RecordLayout
    sock: socket.socket
    subscribed_at: float | None = None
    heard_at: float | None = None


class SensorSubscriber:
    """Subscribe to each record type's server on ``host`` and feed ``readings``."""

    def __init__(
        self,
        host: str,
        records: Sequence[RecordLayout],
        readings: LatestReadings,
        *,
        resubscribe_s: float = RESUBSCRIBE_S,
        silence_s: float = SILENCE_S,
        bind_host: str = "",
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.host = host
        self.records = list(records)
        self.readings = readings
        self.resubscribe_s = resubscribe_s
        self.silence_s = silence_s
        self.bind_host = bind_host
        self.clock = clock
        self.stats = SensorStats()
        self._streams: list[_Stream] = []
        self._selector: selectors.BaseSelector | None = None
        self._board_ip = ""

    def open(self) -> None:
        self._board_ip = socket.gethostbyname(self.host)
        self._selector = selectors.DefaultSelector()
        for record in self.records:
            if record.provisional:
                log.warning(
                    "sensor record %s uses a provisional layout: %s", record.name, record.source
                )
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.bind((self.bind_host, 0))
            sock.setblocking(False)
            stream = _Stream(record, sock)
            self._streams.append(stream)
            self._selector.register(sock, selectors.EVENT_READ, stream)

    def close(self) -> None:
        if self._selector is not None:
            self._selector.close()
            self._selector = None
        for stream in self._streams:
            stream.sock.close()
        self._streams.clear()

    def __enter__(self) -> SensorSubscriber:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def poll(self, timeout_s: float) -> int:
        """One unit of work: subscribe where due, then decode the datagrams that arrive within
        ``timeout_s``. Returns how many records were decoded."""
        assert self._selector is not None, "open() first"
        for stream in self._streams:
            if self._due(stream, self.clock()):
                self._subscribe(stream)
        decoded = 0
        for key, _events in self._selector.select(timeout_s):
            decoded += self._drain(key.data)
        self.readings.expire()
        return decoded

    def run(self, stop: threading.Event, poll_s: float = 0.2) -> None:
        """Poll until ``stop`` is set (for a thread of the bridge)."""
        while not stop.is_set():
            self.poll(poll_s)

    # -- internals ------------------------------------------------------------------------------

    def _due(self, stream: _Stream, now: float) -> bool:
        if stream.subscribed_at is None or now - stream.subscribed_at >= self.resubscribe_s:
            return True
        last_sign = max(stream.subscribed_at, stream.heard_at or stream.subscribed_at)
        return now - last_sign >= self.silence_s

    def _subscribe(self, stream: _Stream) -> None:
        stream.subscribed_at = self.clock()
        try:
            stream.sock.sendto(stream.record.subscribe, (self._board_ip, stream.record.port))
        except OSError as exc:  # the board is down or the link is not up yet: try again later
            self.stats.send_errors += 1
            log.warning("cannot subscribe to %s on %s: %s", stream.record.name, self.host, exc)
            return
        self.stats.subscriptions += 1

    def _drain(self, stream: _Stream) -> int:
        decoded = 0
        while True:
            try:
                data, (ip, _port) = stream.sock.recvfrom(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return decoded
            except OSError as exc:  # e.g. ICMP port unreachable from an earlier subscription
                log.debug("sensor socket %s: %s", stream.record.name, exc)
                return decoded
            self.stats.datagrams += 1
            if ip != self._board_ip:
                self.stats.foreign += 1
                continue
            decoded += self._decode(stream, data)

    def _decode(self, stream: _Stream, data: bytes) -> int:
        try:
            result = stream.record.decode(data)
        except RecordError as exc:
            self.stats.dropped[exc.reason] += 1
            log.warning("dropped a %s datagram (%s): %s", stream.record.name, exc, data[:64].hex())
            return 0
        stream.heard_at = self.clock()
        self.stats.records += 1
        for name, reason in result.dropped.items():
            self.stats.readings_dropped[name] += 1
            log.warning("dropped reading %s: %s", name, reason)
        self.readings.update(result.readings)
        return 1


def main(argv: list[str] | None = None) -> int:
    """Subscribe to the board (or the stand-in) and print each record's readings."""
    parser = argparse.ArgumentParser(prog="python -m sms.bridge.sensors", description=main.__doc__)
    parser.add_argument("--host", default="127.0.0.1", help="the payload board's address")
    parser.add_argument("--layouts", help="a sensor_layouts.toml (default: the shipped one)")
    parser.add_argument("--seconds", type=float, default=10.0, help="how long to watch")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(message)s")
    readings = LatestReadings()
    table = RecordTable.load(args.layouts)
    deadline = time.monotonic() + args.seconds
    with SensorSubscriber(args.host, list(table.records.values()), readings) as subscriber:
        while time.monotonic() < deadline:
            if subscriber.poll(0.5):
                print(readings.snapshot(), flush=True)
    print(f"stats: {subscriber.stats}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
