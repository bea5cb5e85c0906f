"""The modem simulator's control socket: another process has the modem receive an SMS."""

from __future__ import annotations

import socket
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from sms.modem.control import ControlError, ControlServer, NotListening, send_sms
from sms.modem.simulator import SimulatedModem


@pytest.fixture
def where() -> Iterator[Path]:
    # A short folder: a Unix socket's path is limited to ~100 bytes (pytest's tmp_path is long).
    with tempfile.TemporaryDirectory(prefix="ctl-") as folder:
        yield Path(folder) / "modem.sock"


def test_an_sms_sent_through_the_socket_arrives_at_the_modem(where: Path) -> None:
    modem = SimulatedModem()
    modem.cnmi_mt = 1  # as the driver sets it (AT+CNMI=2,1): stored and announced
    told = []
    server = ControlServer(modem, where, on_sms=lambda *a: told.append(a)).start()
    try:
        assert stat.S_IMODE(where.stat().st_mode) == 0o600
        assert send_sms(where, "+61400000001", "#FHEAD 230") == 1
        assert send_sms(where, "+61400000001", "#STATUS") == 2
    finally:
        server.stop()
    assert [(m.number, m.text) for m in modem.store.values()] == [
        ("+61400000001", "#FHEAD 230"),
        ("+61400000001", "#STATUS"),
    ]
    assert b'+CMTI: "SM",1' in modem.take_output()
    assert told == [("+61400000001", "#FHEAD 230", 1), ("+61400000001", "#STATUS", 2)]
    assert not where.exists()  # removed at stop


def test_a_full_store_and_bad_requests_are_answered_not_raised(where: Path) -> None:
    modem = SimulatedModem(capacity=1)
    server = ControlServer(modem, where).start()
    try:
        send_sms(where, "+61400000001", "one")
        with pytest.raises(ControlError, match="SIM store is full"):
            send_sms(where, "+61400000001", "two")
        with pytest.raises(ControlError, match="non-empty strings"):
            send_sms(where, "", "three")
        for junk in (b"not json\n", b'{"number": 1}\n', b"[]\n"):
            with socket.socket(socket.AF_UNIX) as client:
                client.connect(str(where))
                client.sendall(junk)
                assert b'"error"' in client.recv(1024)
        with pytest.raises(ControlError, match="full"):  # still serving after the junk
            send_sms(where, "+61400000002", "four")
    finally:
        server.stop()
    assert len(modem.store) == 1


def test_no_server_is_told_plainly(where: Path) -> None:
    with pytest.raises(NotListening, match=f"no modem simulator listening at {where}"):
        send_sms(where, "+61400000001", "#STATUS")
    where.touch()  # a stale file left by a demo that was killed
    with pytest.raises(NotListening):
        send_sms(where, "+61400000001", "#STATUS")


def test_a_stale_socket_file_is_replaced(where: Path) -> None:
    where.touch()
    server = ControlServer(SimulatedModem(), where).start()
    try:
        assert send_sms(where, "+61400000001", "#STATUS") == 1
    finally:
        server.stop()
