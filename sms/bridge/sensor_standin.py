"""A stand-in for the payload board's UDP data servers, for tests and demos.

References: docs/wave-glider.md#sensors. A data server is subscribed to by sending a packet to the
relevant port number on the payload board. The payload board will send data using UDP to
whichever IP address last contacted it. Each :class:`RecordServer` does exactly that for one
record type of ``sensor_layouts.toml``: any datagram makes its sender the subscriber (replacing
the previous one), and the record goes to that address every ``period_s``.

``python -m sms.bridge.sensor_standin`` serves every record type of the table on 127.0.0.1 with
slowly varying demo values until Ctrl-C (or ``--seconds``). No Django.
"""

from __future__ import annotations

import argparse
import math
import select
import socket
import sys
import threading
import time
from collections.abc import Callable, Mapping

from .records import RecordLayout, RecordTable

PERIOD_S = 1.0
Values = Callable[[], Mapping[str, float]]


class RecordServer:
    """One data server: remembers the last sender and sends it a record every ``period_s``."""

    def __init__(
        self,
        record: RecordLayout,
        values: Values,
        *,
        host: str = "127.0.0.1",
        port: int | None = None,
        period_s: float = PERIOD_S,
    ) -> None:
        self.record = record
        self.values = values
        self.period_s = period_s
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((host, record.port if port is None else port))
        self.port = self.sock.getsockname()[1]
        self.subscriber: tuple[str, int] | None = None
        self.subscriptions = 0
        self.sent = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> RecordServer:
        self._thread = threading.Thread(target=self.serve, name=f"standin-{self.record.name}")
        self._thread.daemon = True
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5)
        self.sock.close()

    def send_raw(self, data: bytes) -> None:
        """Send ``data`` as is to the subscriber (tests: garbage, short records)."""
        if self.subscriber is not None:
            self.sock.sendto(data, self.subscriber)

    def serve(self) -> None:
        next_send = time.monotonic()
        while not self._stop.is_set():
            wait = max(0.0, min(next_send - time.monotonic(), 0.1))
            ready, _, _ = select.select([self.sock], [], [], wait)
            if ready:
                try:
                    _data, sender = self.sock.recvfrom(2048)
                except OSError:
                    continue
                self.subscriber = sender  # "whichever IP address last contacted it"
                self.subscriptions += 1
            if time.monotonic() >= next_send:
                next_send += self.period_s
                if self.subscriber is not None:
                    try:
                        self.sock.sendto(self.record.encode(self.values()), self.subscriber)
                        self.sent += 1
                    except OSError:
                        pass  # the subscriber went away; it will subscribe again


# The readings of the real PIB's status block (§8.4 of docs/level2.md, captured): the demo's centre.
CAPTURED = {
    "humidity_temp_c": 21.0,
    "humidity_pct": 35.0,
    "pressure_temp_c": 21.0,
    "pressure_kpa": 100.0,
    "leak1": 0.0,
    "leak2": 0.0,
}


def demo_values(record: RecordLayout, start: float | None = None) -> Values:
    """The captured readings (or a field's mid-range) drifting slowly: ±2 % over ten minutes."""
    t0 = time.monotonic() if start is None else start
    centre = {
        f.reading: CAPTURED.get(f.reading, ((f.minimum or 0.0) + (f.maximum or 0.0)) / 2)
        for f in record.fields
    }

    def values() -> dict[str, float]:
        drift = 1 + 0.02 * math.sin((time.monotonic() - t0) * 2 * math.pi / 600)
        return {name: round(value * drift, 2) for name, value in centre.items()}

    return values


def main(argv: list[str] | None = None) -> int:
    """Serve every record type of the layout table with demo values."""
    parser = argparse.ArgumentParser(
        prog="python -m sms.bridge.sensor_standin", description=main.__doc__
    )
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--layouts", help="a sensor_layouts.toml (default: the shipped one)")
    parser.add_argument("--period", type=float, default=PERIOD_S, help="seconds between records")
    parser.add_argument("--seconds", type=float, default=0.0, help="stop after (0: Ctrl-C)")
    args = parser.parse_args(argv)
    table = RecordTable.load(args.layouts)
    servers = [
        RecordServer(r, demo_values(r), host=args.host, period_s=args.period).start()
        for r in table.records.values()
    ]
    for server in servers:
        print(f"{server.record.name}: udp {args.host}:{server.port}", flush=True)
    try:
        if args.seconds:
            time.sleep(args.seconds)
        else:
            threading.Event().wait()
    except KeyboardInterrupt:
        pass
    finally:
        for server in servers:
            server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
