"""The SBD modem driver against the simulator through a real pseudo-terminal.

Timeouts are configured short per test; the backoff's sleeps are recorded (not slept) so the
retry waits can be checked exactly; faults come from the simulator's switches.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
import serial

from edge_client.contract.backoff import after_failures
from edge_client.sbd import (
    MessageRefused,
    SbdConfig,
    SbdModem,
    SbdTimeout,
    SessionFailed,
)
from edge_client.sbd.simulator import SbdModemServer, SimulatedSbdModem

pytestmark = pytest.mark.slow

FIRST = 0.5  # the first backoff wait; recorded, not slept


class Sleeps(list[float]):
    """The driver's sleep: records each wait and runs ``then`` (a test's hook) instead."""

    def __init__(self) -> None:
        super().__init__()
        self.then = lambda: None

    def __call__(self, seconds: float) -> None:
        self.append(seconds)
        self.then()


@pytest.fixture
def sim() -> SimulatedSbdModem:
    return SimulatedSbdModem()


@pytest.fixture
def server(sim: SimulatedSbdModem) -> Iterator[SbdModemServer]:
    with SbdModemServer(sim) as server:
        yield server


@pytest.fixture
def sleeps() -> Sleeps:
    return Sleeps()


def make(server: SbdModemServer, sleeps: Sleeps, **overrides: object) -> SbdModem:
    fast: dict[str, object] = {
        "command_timeout_s": 0.5,
        "csq_timeout_s": 0.5,
        "write_timeout_s": 0.5,
        "session_timeout_s": 1.0,
        "wake_timeout_s": 0.2,
        "settle_s": 0.05,
        "backoff_first_s": FIRST,
        "backoff_cap_s": 60.0,
        "session_attempts": 4,
    }
    fast.update(overrides)
    return SbdModem(SbdConfig(server.url, **fast), sleep=sleeps)  # type: ignore[arg-type]


@pytest.fixture
def modem(server: SbdModemServer, sleeps: Sleeps) -> Iterator[SbdModem]:
    modem = make(server, sleeps)
    yield modem
    modem.close()


# -- sending and receiving ----------------------------------------------------------------------


def test_an_mo_message_is_written_sent_and_cleared(modem: SbdModem, sim: SimulatedSbdModem) -> None:
    payload = bytes(range(256))  # every byte value: CR, LF, Ctrl-Z, 0x00 are data here
    result = modem.exchange(payload)
    assert (result.mo_sent, result.momsn, result.mt, result.mt_queued) == (True, 0, None, 0)
    assert result.attempts == 1
    assert sim.delivered == [payload]
    assert sim.mo_buffer is None  # cleared: the next session cannot send it again
    assert sim.commands[:5] == ["AT", "ATE0", "AT&K0", "AT&D0", "AT+SBDMTA=1"]
    assert sim.commands[5:] == ["AT+SBDWB=256", "AT+SBDIX", "AT+SBDD0"]


def test_the_momsn_counts_up_with_every_session(modem: SbdModem, sim: SimulatedSbdModem) -> None:
    assert [modem.exchange(b"fix %d" % i).momsn for i in range(3)] == [0, 1, 2]
    assert modem.exchange(None).momsn == 3  # a mailbox check is a session too
    assert sim.delivered == [b"fix 0", b"fix 1", b"fix 2"]


def test_a_mailbox_check_receives_mt_messages_one_per_session(
    modem: SbdModem, sim: SimulatedSbdModem
) -> None:
    first = b"\x00\x05\r\nOK\r\nSBDRING\r\n"  # looks like framing and answers: it is data
    sim.queue_mt(first, ring=False)
    sim.queue_mt(b"second", ring=False)
    one = modem.exchange(None)
    assert (one.mo_sent, one.mt, one.mtmsn, one.mt_queued) == (False, first, 1, 1)
    two = modem.exchange(None)
    assert (two.mt, two.mtmsn, two.mt_queued) == (b"second", 2, 0)
    three = modem.exchange(None)
    assert (three.mt, three.mt_queued) == (None, 0)
    assert sim.delivered == []  # nothing but blank mailbox checks went up


def test_a_mailbox_check_never_resends_what_is_left_in_the_mo_buffer(
    modem: SbdModem, sim: SimulatedSbdModem
) -> None:
    modem.open()
    sim.mo_buffer = b"sent yesterday"  # e.g. the clear after a send was lost
    modem.exchange(None)
    assert sim.delivered == []


def test_a_session_sends_and_receives_at_once(modem: SbdModem, sim: SimulatedSbdModem) -> None:
    sim.queue_mt(b"#RTL", ring=False)
    result = modem.exchange(b"report")
    assert (result.mo_sent, result.mt, result.mt_queued) == (True, b"#RTL", 0)
    assert sim.delivered == [b"report"]


# -- ring alerts ----------------------------------------------------------------------------------


def test_a_ring_is_awaited_and_answered_with_sbdixa(
    modem: SbdModem, sim: SimulatedSbdModem
) -> None:
    assert modem.wait_for_ring(0.2) is False
    sim.queue_mt(b"come home")
    assert modem.wait_for_ring(2.0) is True
    assert modem.ring_pending
    result = modem.exchange(None)
    assert result.mt == b"come home"
    assert "AT+SBDIXA" in sim.commands and not modem.ring_pending
    assert modem.rings == 1


def test_a_ring_during_a_write_makes_the_session_answer_it(
    modem: SbdModem, sim: SimulatedSbdModem
) -> None:
    modem.open()
    sim.queue_mt(b"urgent")  # SBDRING reaches the driver amid the AT+SBDWB dialogue
    result = modem.exchange(b"fix")
    assert (result.mo_sent, result.mt) == (True, b"urgent")
    assert sim.commands[-3:] == ["AT+SBDIXA", "AT+SBDD0", "AT+SBDRB"]


def test_without_ring_alerts_no_sbdring_comes(server: SbdModemServer, sleeps: Sleeps) -> None:
    modem = make(server, sleeps, ring_alerts=False)
    try:
        modem.open()
        server.modem.queue_mt(b"quiet")
        assert modem.wait_for_ring(0.3) is False
        assert modem.exchange(None).mt == b"quiet"
    finally:
        modem.close()
    assert "AT+SBDMTA=0" in server.modem.commands


# -- failures and retries -------------------------------------------------------------------------


def test_failed_sessions_are_retried_with_the_contract_backoff(
    modem: SbdModem, sim: SimulatedSbdModem, sleeps: Sleeps
) -> None:
    sim.fail_codes = [32, 18, 35]  # no service, RF drop, busy: then the sky clears
    result = modem.exchange(b"fix")
    assert result.mo_sent and result.attempts == 4 and result.momsn == 0
    assert sleeps == [after_failures(FIRST, n, cap=60.0) for n in range(3)] == [0.5, 1.0, 2.0]
    assert sim.commands.count("AT+SBDIX") == 4 and sim.commands.count("AT+SBDWB=3") == 1
    assert sim.delivered == [b"fix"]


def test_try_later_waits_three_minutes(
    modem: SbdModem, sim: SimulatedSbdModem, sleeps: Sleeps
) -> None:
    sim.fail_codes = [36]
    assert modem.exchange(b"fix").attempts == 2
    assert sleeps == [180.0]


@pytest.mark.parametrize("code", [15, 16, 34, 65])
def test_a_permanent_failure_is_not_retried(
    modem: SbdModem, sim: SimulatedSbdModem, sleeps: Sleeps, code: int
) -> None:
    sim.fail_codes = [code]
    with pytest.raises(SessionFailed) as caught:
        modem.exchange(b"fix")
    assert caught.value.permanent and caught.value.code == code and caught.value.attempts == 1
    assert sleeps == [] and sim.commands.count("AT+SBDIX") == 1 and sim.delivered == []


def test_no_network_gives_up_after_the_attempts_then_works_again(
    modem: SbdModem, sim: SimulatedSbdModem, sleeps: Sleeps
) -> None:
    sim.network = False
    with pytest.raises(SessionFailed) as caught:
        modem.exchange(b"fix")
    assert not caught.value.permanent
    assert (caught.value.code, caught.value.attempts) == (32, 4)
    assert "no network service" in str(caught.value)
    assert len(sleeps) == 3 and sim.delivered == []
    sim.network = True
    assert modem.exchange(b"fix").mo_sent
    assert sim.delivered == [b"fix"]


def test_a_checksum_answered_2_is_written_again(modem: SbdModem, sim: SimulatedSbdModem) -> None:
    sim.faults.corrupt_write = True  # one byte flipped on the line
    assert modem.exchange(b"hello").mo_sent
    assert sim.commands.count("AT+SBDWB=5") == 2
    assert sim.delivered == [b"hello"]


def test_a_write_timeout_answered_1_without_ok_is_written_again(
    modem: SbdModem, sim: SimulatedSbdModem
) -> None:
    sim.write_timeout_s = 0.2  # the ISU's is 60 s
    sim.faults.lose_write_bytes = 2  # the modem waits for two bytes that never come
    result = modem.exchange(b"hello")
    assert result.mo_sent and result.attempts == 1  # no wait for an OK that never comes
    assert sim.commands.count("AT+SBDWB=5") == 2
    assert sim.delivered == [b"hello"]


def test_a_write_that_keeps_failing_counts_as_a_failed_attempt(
    server: SbdModemServer, sleeps: Sleeps
) -> None:
    modem = make(server, sleeps, write_attempts=1)
    server.modem.faults.corrupt_write = True
    try:
        result = modem.exchange(b"hello")
    finally:
        modem.close()
    assert result.attempts == 2 and sleeps == [FIRST]
    assert server.modem.delivered == [b"hello"]


def test_the_simulator_answers_a_bad_checksum_with_2(server: SbdModemServer) -> None:
    with serial.serial_for_url(server.url, timeout=0.5) as port:
        port.write(b"ATE0\r")
        assert b"OK" in port.read_until(b"OK\r\n")
        port.write(b"AT+SBDWB=5\r")
        assert port.read_until(b"READY\r\n").endswith(b"READY\r\n")
        port.write(b"hello\x00\x00")  # the right checksum is 0x0214
        assert port.read_until(b"OK\r\n") == b"\r\n2\r\n\r\nOK\r\n"
        port.write(b"AT+SBDWB=341\r")
        assert port.read_until(b"OK\r\n") == b"\r\n3\r\n\r\nOK\r\n"  # no READY for 341


@pytest.mark.parametrize("size", [0, 341, 2000])
def test_a_message_the_modem_cannot_take_is_refused_before_sending(
    modem: SbdModem, sim: SimulatedSbdModem, size: int
) -> None:
    with pytest.raises(MessageRefused, match="1 to 340 bytes"):
        modem.exchange(b"x" * size)
    assert sim.commands == []  # the port was not even opened
    assert modem.exchange(b"x" * 340).mo_sent


def test_garbage_on_the_line_is_logged_and_skipped(modem: SbdModem, sim: SimulatedSbdModem) -> None:
    modem.open()
    sim.faults.garbage = True  # a junk line before every answer, the frame's too
    sim.garbage()
    sim.queue_mt(b"through the noise", ring=False)
    result = modem.exchange(b"fix")
    assert (result.mo_sent, result.mt) == (True, b"through the noise")
    assert modem.noise_lines >= 4
    assert sim.delivered == [b"fix"]


def test_a_corrupt_mt_frame_is_read_again(modem: SbdModem, sim: SimulatedSbdModem) -> None:
    sim.queue_mt(b"read me twice", ring=False)
    sim.faults.corrupt_frame = True
    assert modem.exchange(None).mt == b"read me twice"
    assert sim.commands.count("AT+SBDRB") == 2


def test_a_deaf_modem_times_out_then_is_set_up_again(
    modem: SbdModem, sim: SimulatedSbdModem
) -> None:
    modem.open()
    sim.go_deaf(0.6)
    with pytest.raises(SbdTimeout):
        modem.signal()
    assert not modem.ready
    sim.signal = 2
    time.sleep(0.4)  # the deaf spell ends
    assert modem.signal() == 2
    assert sim.commands[-2:] == ["AT+SBDMTA=1", "AT+CSQ"]  # set up again first


def test_a_session_answer_that_never_comes_is_a_failed_attempt(
    modem: SbdModem, sim: SimulatedSbdModem, sleeps: Sleeps
) -> None:
    # Past the 1 s session timeout; a busy ISU answers nothing else until the session ends,
    # so the wake-up after the timeout waits for it (as on a real modem).
    sim.faults.session_delay_s = 1.5
    sleeps.then = lambda: setattr(sim.faults, "session_delay_s", 0.0)
    result = modem.exchange(b"fix")
    assert result.mo_sent and result.attempts in (2, 3)
    assert modem.noise_lines >= 1  # the late +SBDIX answer, dropped
    # The first session did go through: the retry sends it again (documented: at least once).
    assert sim.delivered == [b"fix", b"fix"]


def test_a_weak_signal_holds_the_session_back(server: SbdModemServer, sleeps: Sleeps) -> None:
    sim = server.modem
    modem = make(server, sleeps, min_signal=2, session_attempts=3)
    sim.signal = 1
    sleeps.then = lambda: setattr(sim, "signal", 3) if len(sleeps) == 2 else None
    try:
        result = modem.exchange(b"fix")
    finally:
        modem.close()
    assert result.attempts == 3
    assert sim.commands.count("AT+SBDIX") == 1 and sim.commands.count("AT+CSQ") == 3


def test_a_port_that_cannot_open_is_a_temporary_failure(sleeps: Sleeps) -> None:
    modem = SbdModem(SbdConfig("/dev/does-not-exist", session_attempts=2), sleep=sleeps)
    with pytest.raises(SessionFailed, match="cannot open") as caught:
        modem.exchange(b"fix")
    assert not caught.value.permanent and len(sleeps) == 1
