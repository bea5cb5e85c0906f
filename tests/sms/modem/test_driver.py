"""The modem driver against the simulator through a real pseudo-terminal and a TCP socket.

References: docs/sms.md, 'The GSM modem' (what a robust driver does).
Timeouts are configured short per test; faults come from the simulator's switches, not sleeps.
"""

from __future__ import annotations

from collections.abc import Iterator
from datetime import UTC, datetime

import pytest

from sms.modem import (
    CommandError,
    Modem,
    ModemConfig,
    ModemError,
    ModemEvents,
    ModemTimeout,
    PinRequired,
    ReceivedSms,
    SendUnconfirmed,
    UnsendableText,
    receive_all,
)
from sms.modem.simulator import ModemServer, SimulatedModem

pytestmark = pytest.mark.slow

ALICE = "+61400000001"
BOB = "+61400000002"
WHEN = datetime(2026, 11, 23, 4, 5, tzinfo=UTC)
SETUP = [
    "AT",
    "ATE0",
    "AT+CMEE=1",
    "AT+CPIN?",
    "AT+CMGF=1",
    'AT+CSCS="GSM"',
    'AT+CPMS="SM","SM","SM"',
    "AT+CNMI=2,1,0,0,0",
    "AT+CSDH=1",
]


def config(url: str, **overrides: object) -> ModemConfig:
    fast = {
        "command_timeout_s": 0.5,
        "send_timeout_s": 1.0,
        "wake_timeout_s": 0.2,
        "wake_attempts": 3,
        "settle_s": 0.05,
        "reconnect_delay_s": 0.05,
        "reconnect_max_s": 0.2,
        "relist_interval_s": None,
    }
    fast.update(overrides)
    return ModemConfig(url, **fast)  # type: ignore[arg-type]


class Database:
    """An in-memory stand-in for the SmsMessage table, keyed as the real one: (number, text,
    modem timestamp). ``store`` "commits" before returning, and records what was on the SIM
    at that moment so tests can prove the delete came after."""

    def __init__(self, sim: SimulatedModem) -> None:
        self.sim = sim
        self.rows: dict[tuple[str, str, datetime | None], ReceivedSms] = {}
        self.calls = 0
        self.on_sim_when_stored: list[bool] = []

    def store(self, sms: ReceivedSms) -> None:
        self.calls += 1
        on_sim = self.sim.store.get(sms.index or 0)
        self.on_sim_when_stored.append(on_sim is not None and on_sim.text == sms.text)
        self.rows.setdefault(sms.key, sms)  # idempotent, like a unique constraint

    def texts(self) -> list[str]:
        return sorted(sms.text for sms in self.rows.values())


@pytest.fixture(params=["pty", "tcp:0"])
def served(request: pytest.FixtureRequest) -> Iterator[tuple[SimulatedModem, ModemServer]]:
    sim = SimulatedModem(capacity=10)
    with ModemServer(sim, request.param) as server:
        yield sim, server


@pytest.fixture
def sim_pty() -> Iterator[tuple[SimulatedModem, ModemServer]]:
    sim = SimulatedModem(capacity=10)
    with ModemServer(sim, "pty") as server:
        yield sim, server


def until_relist(modem: Modem, rounds: int = 10) -> ModemEvents:
    """Poll until the driver asks for a re-list (it has recovered); fail after ``rounds``."""
    for _ in range(rounds):
        events = modem.poll_events(0.5)
        if events.relist:
            return events
    raise AssertionError("the driver never recovered")


def opened(server: ModemServer, **overrides: object) -> Modem:
    modem = Modem(config(server.url, **overrides))
    modem.open()
    return modem


def test_set_up_from_a_fresh_echoing_modem(served) -> None:  # type: ignore[no-untyped-def]
    sim, server = served
    assert sim.echo and not sim.text_mode
    modem = opened(server)
    try:
        assert sim.commands == SETUP
        assert not sim.echo and sim.text_mode and sim.charset == "GSM" and sim.cnmi_mt == 1
        assert modem.store_usage == (0, 10)
        assert modem.poll_events(0.1).relist  # the first set-up asks for a full listing
    finally:
        modem.close()


def test_receive_reads_stores_and_deletes_only_after_the_store(served) -> None:  # type: ignore[no-untyped-def]
    sim, server = served
    db = Database(sim)
    modem = opened(server)
    try:
        assert receive_all(modem, db.store, modem.poll_events(0.1)) == 0
        index = sim.inject(ALICE, "#FHEAD 230", WHEN)
        events = modem.poll_events(2.0)
        assert events.indices == (index,) and not events.relist
        assert receive_all(modem, db.store, events) == 1
        [row] = db.rows.values()
        assert (row.number, row.text, row.timestamp, row.index) == (ALICE, "#FHEAD 230", WHEN, 1)
        assert db.on_sim_when_stored == [True]  # still on the SIM when stored…
        assert sim.store == {}  # …and deleted after
        assert sim.commands[-2:] == ["AT+CMGR=1", "AT+CMGD=1"]
    finally:
        modem.close()


def test_a_message_stored_while_the_driver_was_down_is_found_on_start(served) -> None:  # type: ignore[no-untyped-def]
    sim, server = served
    sim.inject(ALICE, "#STATUS", WHEN)  # arrives before the driver runs: no one sees +CMTI
    sim.inject(BOB, "#HELP\nplease", WHEN)
    db = Database(sim)
    modem = opened(server)
    try:
        events = modem.poll_events(0.5)
        assert events.relist
        assert receive_all(modem, db.store, events) == 2
        assert db.texts() == ["#HELP\nplease", "#STATUS"]
        assert sim.store == {}
    finally:
        modem.close()


def test_send_waits_for_the_prompt_and_returns_the_reference(served) -> None:  # type: ignore[no-untyped-def]
    sim, server = served
    modem = opened(server)
    try:
        assert modem.send(ALICE, "#FHEAD 230 OK") == 1
        assert modem.send(BOB, "@ home £5 _x_ é") == 2  # '@' is byte 0x00 on the wire
        assert [(s.number, s.text) for s in sim.sent] == [
            (ALICE, "#FHEAD 230 OK"),
            (BOB, "@ home £5 _x_ é"),
        ]
    finally:
        modem.close()


def test_send_errors_say_whether_to_retry(sim_pty) -> None:  # type: ignore[no-untyped-def]
    sim, server = sim_pty
    modem = opened(server)
    try:
        sim.faults.send_error = 331
        with pytest.raises(CommandError) as temporary:
            modem.send(ALICE, "#HOLD OK")
        assert temporary.value.temporary and temporary.value.code == 331
        sim.faults.send_error = 21
        with pytest.raises(CommandError) as permanent:
            modem.send(ALICE, "#HOLD OK")
        assert permanent.value.permanent and "rejected" in str(permanent.value)
        assert modem.send(ALICE, "#HOLD OK") == 1  # the retry after the temporary error
        for text in ("#RUDDER [1]", "€5", "Ξ", "x" * 161, "中"):
            with pytest.raises(UnsendableText):
                modem.send(ALICE, text)
        assert len(sim.sent) == 1
    finally:
        modem.close()


def test_a_send_whose_answer_never_comes_is_unconfirmed(sim_pty) -> None:  # type: ignore[no-untyped-def]
    sim, server = sim_pty
    modem = opened(server, send_timeout_s=0.3)
    try:
        sim.faults.send_delay_s = 0.6  # the network is slow to confirm
        with pytest.raises(SendUnconfirmed) as error:
            modem.send(ALICE, "#FHEAD 230 OK")
        assert error.value.temporary
        assert [s.text for s in sim.sent] == ["#FHEAD 230 OK"]  # why it is only "unconfirmed"
        sim.faults.send_delay_s = 0.0
        # The late +CMGS is drained by the reset and not taken as the next answer.
        assert modem.send(ALICE, "#FHEAD 231 OK") == 2
    finally:
        modem.close()


def test_read_errors_and_empty_slots(sim_pty) -> None:  # type: ignore[no-untyped-def]
    sim, server = sim_pty
    modem = opened(server)
    try:
        assert modem.read(5) is None  # an empty slot answers a bare OK
        assert modem.read(99) is None  # +CMS ERROR: 321, invalid index
        sim.inject(ALICE, "#LIGHT", WHEN)
        sim.faults.read_error = 500
        with pytest.raises(CommandError) as error:
            modem.stored_messages()
        assert error.value.temporary
        assert [m.text for m in modem.stored_messages()] == ["#LIGHT"]
    finally:
        modem.close()


def test_garbage_and_urcs_in_the_middle_of_replies_lose_nothing(served) -> None:  # type: ignore[no-untyped-def]
    sim, server = served
    db = Database(sim)
    modem = opened(server)
    try:
        receive_all(modem, db.store, modem.poll_events(0.1))
        sim.faults.garbage = True
        sim.faults.urc_mid_reply = True
        first = sim.inject(ALICE, "#FHEAD 1", WHEN)
        second = sim.inject(BOB, "#FHEAD 2", WHEN)
        # Their +CMTI lines are held back and come out inside the next answer.
        answer = modem.command("AT+CSQ")
        assert len(answer.lines) == 2 and answer.lines[-1] == "+CSQ: 21,99"  # junk, answer
        events = modem.poll_events(0.1)
        assert events.indices == (first, second)
        sim.garbage(40)  # junk between commands too: logged as noise
        assert modem.poll_events(0.3).indices == ()
        assert modem.noise_lines == 1
        assert receive_all(modem, db.store, events) == 2
        assert db.texts() == ["#FHEAD 1", "#FHEAD 2"] and sim.store == {}
        assert modem.send(ALICE, "#FHEAD 1 OK") == 1
    finally:
        modem.close()


def test_a_modem_reset_mid_session_loses_nothing_and_delivers_nothing_twice(served) -> None:  # type: ignore[no-untyped-def]
    sim, server = served
    db = Database(sim)
    modem = opened(server)
    try:
        receive_all(modem, db.store, modem.poll_events(0.1))
        sim.inject(ALICE, "#HOLD", WHEN)
        events = modem.poll_events(2.0)

        def store_then_modem_resets(sms: ReceivedSms) -> None:
            db.store(sms)  # committed…
            sim.reset(boot_s=0.1)  # …and the modem restarts before the delete

        with pytest.raises(ModemError) as error:
            receive_all(modem, store_then_modem_resets, events)
        assert error.value.temporary
        assert [m.text for m in sim.store.values()] == ["#HOLD"]  # still on the SIM
        events = until_relist(modem)  # notices the restart, sets up again, asks to re-list
        assert modem.ready and modem.resets == 2  # the first set-up, then again
        assert sim.text_mode and not sim.echo
        assert receive_all(modem, db.store, events) == 1
        assert db.calls == 2 and db.texts() == ["#HOLD"]  # seen twice, stored once
        assert sim.store == {}
    finally:
        modem.close()


def test_a_modem_whose_sms_stack_starts_late_is_set_up_when_ready(sim_pty) -> None:  # type: ignore[no-untyped-def]
    sim, server = sim_pty
    db = Database(sim)
    modem = opened(server)
    try:
        receive_all(modem, db.store, modem.poll_events(0.1))
        sim.inject(ALICE, "#FCOURSE 10", WHEN)
        sim.reset(boot_s=0.05, sms_ready_s=0.6)  # +CMS ERROR: 302 until "SMS Ready"
        events = until_relist(modem)
        assert sim.commands.count('AT+CPMS="SM","SM","SM"') >= 3  # refused, then accepted
        assert receive_all(modem, db.store, events) == 1 and db.texts() == ["#FCOURSE 10"]
    finally:
        modem.close()


def test_a_message_whose_store_fails_stays_on_the_sim(sim_pty) -> None:  # type: ignore[no-untyped-def]
    sim, server = sim_pty
    db = Database(sim)
    modem = opened(server)
    try:
        sim.inject(ALICE, "#FHEAD 10", WHEN)
        sim.inject(BOB, "#FHEAD 20", WHEN)

        def store(sms: ReceivedSms) -> None:
            if sms.number == ALICE:
                raise RuntimeError("database is locked")
            db.store(sms)

        assert receive_all(modem, store, modem.poll_events(0.5)) == 1
        assert db.texts() == ["#FHEAD 20"]
        assert [m.text for m in sim.store.values()] == ["#FHEAD 10"]  # kept for the next try
    finally:
        modem.close()


def test_nothing_is_delivered_twice_across_a_driver_restart(served) -> None:  # type: ignore[no-untyped-def]
    sim, server = served
    db = Database(sim)
    sim.inject(ALICE, "#WAYPOINT 1", WHEN)
    first = opened(server)
    [sms] = first.stored_messages()
    db.store(sms)
    first.close()  # the process dies between the commit and the delete
    second = opened(server)
    try:
        assert receive_all(second, db.store, second.poll_events(0.5)) == 1
        assert db.calls == 2 and list(db.rows) == [(ALICE, "#WAYPOINT 1", WHEN)]
        assert sim.store == {}
    finally:
        second.close()


def test_a_modem_that_stops_answering_times_out_is_reset_and_recovers(served) -> None:  # type: ignore[no-untyped-def]
    sim, server = served
    db = Database(sim)
    modem = opened(server)
    try:
        receive_all(modem, db.store, modem.poll_events(0.1))
        sim.go_deaf(1.2)  # longer than the 0.5 s command timeout, with room for a slow CI
        sim.inject(ALICE, "#FHEAD 90", WHEN)  # arrives while it is deaf
        with pytest.raises(ModemTimeout):
            modem.command("AT+CSQ")
        assert not modem.ready
        events = until_relist(modem)
        assert modem.ready
        assert receive_all(modem, db.store, events) == 1
        assert db.texts() == ["#FHEAD 90"] and sim.store == {}
        assert sim.commands.count("ATE0") >= 2  # the set-up ran again
    finally:
        modem.close()


def test_a_slow_modem_is_waited_for_within_the_timeout(sim_pty) -> None:  # type: ignore[no-untyped-def]
    sim, server = sim_pty
    modem = opened(server, command_timeout_s=1.0)
    try:
        sim.faults.delay_s = 0.3
        assert modem.send(ALICE, "#LIGHT ON OK") == 1
        assert modem.command("AT+CSQ").result.ok
    finally:
        modem.close()


def test_a_port_that_disappears_is_reopened() -> None:
    sim = SimulatedModem()
    with ModemServer(sim, "tcp:0") as server:
        db = Database(sim)
        modem = opened(server)
        try:
            receive_all(modem, db.store, modem.poll_events(0.1))
            server.drop_client()
            sim.inject(ALICE, "#IR 1", WHEN)
            events = until_relist(modem)  # the +CMTI may have been lost with the connection
            assert modem.opens == 2
            assert receive_all(modem, db.store, events) == 1
            assert db.texts() == ["#IR 1"]
        finally:
            modem.close()


def test_a_sim_that_wants_a_pin_is_a_permanent_error(sim_pty) -> None:  # type: ignore[no-untyped-def]
    sim, server = sim_pty
    sim.pin_ready = False
    modem = Modem(config(server.url))
    with pytest.raises(PinRequired) as error:
        modem.open()
    assert error.value.permanent and "SIM PIN" in str(error.value)
    with pytest.raises(PinRequired):
        modem.poll_events(0.2)
    modem.close()


def test_loop_url_opens_and_times_out_cleanly() -> None:
    # loop:// echoes every byte: the driver sees its own commands and never a result.
    modem = Modem(config("loop://", wake_attempts=2, wake_timeout_s=0.05, reset_attempts=1))
    with pytest.raises(ModemTimeout):
        modem.open()
    modem.close()
