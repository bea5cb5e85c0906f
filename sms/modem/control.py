"""Type an SMS into a running modem simulator from another process (the demo's ``demo_sms``).

:class:`ControlServer` listens on a Unix socket beside a :class:`~.simulator.SimulatedModem`
(the socket file is made private: whoever can write to it can text the glider). A client sends
one JSON line, ``{"number": "+61400000001", "text": "#FHEAD 230"}``, and gets one back:
``{"slot": 3}`` when the SMS arrived at the modem's store, ``{"error": "…"}`` otherwise.
:func:`send_sms` is that client. No Django.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import socket
import threading
from collections.abc import Callable
from pathlib import Path

from .simulator import SimulatedModem

log = logging.getLogger(__name__)

MAX_REQUEST = 4096  # bytes: one SMS of text is far less
TIMEOUT_S = 5.0


class ControlError(Exception):
    """The modem refused the SMS (or answered nonsense)."""


class NotListening(ControlError):
    """No modem simulator at that socket: the demo is not running (or elsewhere)."""


class ControlServer:
    """Inject each SMS a client sends into ``modem``; ``on_sms(number, text, slot)`` is told."""

    def __init__(
        self,
        modem: SimulatedModem,
        path: Path | str,
        on_sms: Callable[[str, str, int | None], None] | None = None,
    ) -> None:
        self.modem = modem
        self.path = Path(path)
        self.on_sms = on_sms or (lambda _n, _t, _s: None)
        self._stop = threading.Event()
        self.path.unlink(missing_ok=True)  # a stale socket from a run that was killed
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self._sock.bind(str(self.path))
        os.chmod(self.path, 0o600)  # the demo's data folder is private too
        self._sock.listen(4)
        self._sock.settimeout(0.2)
        self._thread = threading.Thread(target=self._serve, name="modem-control", daemon=True)

    def start(self) -> ControlServer:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5)
        self._sock.close()
        self.path.unlink(missing_ok=True)

    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                client, _ = self._sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return  # closed under us: stopping
            with client:
                client.settimeout(TIMEOUT_S)
                try:
                    answer = self.handle(_read_line(client))
                    client.sendall(json.dumps(answer).encode() + b"\n")
                except OSError as exc:
                    log.info("modem control: %s", exc)

    def handle(self, raw: bytes) -> dict[str, object]:
        """One request → its answer (bad input is answered, never raised)."""
        try:
            request = json.loads(raw)
            number, text = request["number"], request["text"]
        except (ValueError, TypeError, KeyError):
            return {"error": 'send {"number": "+614…", "text": "…"}'}
        if not isinstance(number, str) or not isinstance(text, str) or not number or not text:
            return {"error": "number and text must be non-empty strings"}
        slot = self.modem.inject(number, text)
        self.on_sms(number, text, slot)
        if slot is None and self.modem.rejected and self.modem.rejected[-1] == (number, text):
            return {"error": "the modem's SIM store is full: the SMS was refused"}
        return {"slot": slot}


def send_sms(path: Path | str, number: str, text: str, timeout_s: float = TIMEOUT_S) -> int | None:
    """Have the modem behind the control socket at ``path`` receive an SMS; its store slot."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.settimeout(timeout_s)
        try:
            sock.connect(str(path))
        except (FileNotFoundError, ConnectionRefusedError) as exc:
            raise NotListening(f"no modem simulator listening at {path} ({exc.strerror})") from None
        sock.sendall(json.dumps({"number": number, "text": text}).encode() + b"\n")
        answer = json.loads(_read_line(sock) or b"{}")
    if "error" in answer:
        raise ControlError(str(answer["error"]))
    return answer.get("slot")


def _read_line(sock: socket.socket) -> bytes:
    data = b""
    with contextlib.suppress(TimeoutError):
        while b"\n" not in data and len(data) < MAX_REQUEST:
            chunk = sock.recv(1024)
            if not chunk:
                break
            data += chunk
    return data.split(b"\n", 1)[0]
