"""Real processes and small network stand-ins for the integration tests (and the benchmark)."""

from __future__ import annotations

import os
import pty
import re
import select
import signal
import socket
import sqlite3
import subprocess
import sys
import threading
import time
import tty
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_REQUEST_LINE = re.compile(rb"(GET|POST|HEAD) (/\S*) HTTP/1\.1\r\n")


def wait_until(predicate: Callable[[], object], timeout: float, what: str = "") -> object:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"timed out after {timeout:g} s waiting for {what or predicate}")


def start(args: list[str], log_path: Path) -> subprocess.Popen:
    """Start ``python <args>`` from the repo root, output to ``log_path``."""
    log = open(log_path, "wb")  # noqa: SIM115 - closed by stop()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": "1"}
    env.pop("NOTIFY_SOCKET", None)
    proc = subprocess.Popen([sys.executable, *args], cwd=ROOT, env=env, stdout=log,
                            stderr=subprocess.STDOUT)  # fmt: skip
    proc.log_file = log  # type: ignore[attr-defined]
    return proc


def stop(proc: subprocess.Popen, timeout: float = 15.0) -> int:
    """SIGTERM, wait, SIGKILL if it will not go. Returns the exit status."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    proc.log_file.close()  # type: ignore[attr-defined]
    return proc.returncode


def outbox_counts(path: Path) -> dict[str, int]:
    """Read a (possibly live) outbox read-only: queued fixes/acks and the counters."""
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    try:
        out = dict(db.execute("SELECT name, value FROM counters").fetchall())
        for kind in ("fix", "ack"):
            out[f"queued_{kind}"] = db.execute(
                "SELECT COUNT(*) FROM outbox WHERE kind = ?", (kind,)
            ).fetchone()[0]
        return out
    finally:
        db.close()


class TcpProxy:
    """A TCP relay in front of a server whose port can be dropped and restored (an outage)."""

    def __init__(self, target: tuple[str, int]) -> None:
        self.target = target
        self.port = 0
        self._listener: socket.socket | None = None
        self._conns: list[socket.socket] = []
        self._lock = threading.Lock()
        self.sent: list[bytearray] = []  # what each connection carried to the server
        self.up()

    def up(self) -> None:
        listener = socket.socket()
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind(("127.0.0.1", self.port))
        listener.listen(16)
        self.port = listener.getsockname()[1]
        self._listener = listener
        threading.Thread(target=self._accept, args=(listener,), daemon=True).start()

    def down(self) -> None:
        """Close the port and cut every open connection (requests in flight die)."""
        with self._lock:
            listener, self._listener = self._listener, None
            conns, self._conns = self._conns, []
        if listener:
            try:
                listener.shutdown(socket.SHUT_RDWR)  # wakes the blocked accept() (Linux)
            except OSError:
                pass
            listener.close()
        for c in conns:
            try:
                c.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            c.close()

    def _accept(self, listener: socket.socket) -> None:
        while True:
            try:
                client, _ = listener.accept()
            except OSError:
                return
            try:
                upstream = socket.create_connection(self.target)
            except OSError:
                client.close()
                continue
            with self._lock:
                self._conns += [client, upstream]
                seen = bytearray()
                self.sent.append(seen)
            for a, b, log in ((client, upstream, seen), (upstream, client, None)):
                threading.Thread(target=self._pipe, args=(a, b, log), daemon=True).start()

    def requests(self) -> list[tuple[str, str]]:
        """(method, path) of every request the client sent through, connection by connection
        (compact JSON bodies hold no CRLF, so a request line is unmistakable)."""
        with self._lock:
            streams = [bytes(s) for s in self.sent]
        found = []
        for stream in streams:
            found += [(m.decode(), p.decode()) for m, p in _REQUEST_LINE.findall(stream)]
        return found

    @staticmethod
    def _pipe(src: socket.socket, dst: socket.socket, log: bytearray | None = None) -> None:
        try:
            while data := src.recv(65536):
                if log is not None:
                    log += data
                dst.sendall(data)
        except OSError:
            pass
        finally:
            try:
                dst.shutdown(socket.SHUT_WR)
            except OSError:
                pass


class ModemStandIn:
    """Plays the F2414 in TELNET + data-trigger mode on the master side of a pty pair.

    Idle until it reads ``don``; then connects to the server and relays bytes both ways
    (anything written right after the trigger is buffered and sent once connected); when the
    server closes the connection it goes back to idle, as the real modem does.
    """

    TRIGGER = b"don"

    def __init__(self, server: tuple[str, int]) -> None:
        self.server = server
        self.master, self._slave = pty.openpty()
        tty.setraw(self._slave)
        self.device = os.ttyname(self._slave)
        self.sessions = 0
        self.bytes_to_server = 0
        self.bytes_from_server = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)
        os.close(self.master)
        os.close(self._slave)

    def _read(self, timeout: float = 0.1) -> bytes:
        ready, _, _ = select.select([self.master], [], [], timeout)
        return os.read(self.master, 4096) if ready else b""

    def _run(self) -> None:
        idle = b""
        while not self._stop.is_set():
            idle += self._read()
            at = idle.find(self.TRIGGER)
            if at < 0:
                idle = idle[-2:]
                continue
            pending, idle = idle[at + len(self.TRIGGER) :], b""
            self._session(pending)

    def _session(self, pending: bytes) -> None:
        self.sessions += 1
        try:
            sock = socket.create_connection(self.server, timeout=5)
        except OSError:
            return  # the real modem would fail to dial: the client times out
        with sock:
            if pending:
                sock.sendall(pending)
                self.bytes_to_server += len(pending)
            while not self._stop.is_set():
                ready, _, _ = select.select([self.master, sock], [], [], 0.1)
                if self.master in ready:
                    data = os.read(self.master, 4096)
                    sock.sendall(data)
                    self.bytes_to_server += len(data)
                if sock in ready:
                    try:
                        data = sock.recv(4096)
                    except BlockingIOError:
                        continue
                    if not data:
                        return  # the server closed: end of this exchange
                    os.write(self.master, data)
                    self.bytes_from_server += len(data)
