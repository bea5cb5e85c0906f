"""The simulated modem's AT interpreter, bytes in and out, no port (sms/modem/simulator.py).

Its output is read back with the driver's own pure reader, so the two sides are checked against
each other; the driver tests then run them through real ptys and sockets.
"""

from __future__ import annotations

from datetime import UTC, datetime

from sms.modem.at import AtReader, Echo, Prompt, Response, Urc
from sms.modem.simulator import POWER_UP_BURST, SimulatedModem, scts

WHEN = datetime(2026, 11, 23, 4, 5, tzinfo=UTC)


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def ask(sim: SimulatedModem, command: str, reader: AtReader | None = None) -> list[object]:
    reader = reader or AtReader()
    reader.start(command)
    sim.receive(command.encode() + b"\r")
    return reader.feed(sim.take_output())


def set_up(sim: SimulatedModem) -> None:
    for command in ("ATE0", "AT+CMEE=1", "AT+CMGF=1", 'AT+CSCS="GSM"', "AT+CNMI=2,1,0,0,0"):
        response = ask(sim, command)[-1]  # after the echo of ATE0
        assert isinstance(response, Response) and response.result.ok


def test_a_fresh_modem_echoes_until_ate0() -> None:
    sim = SimulatedModem()
    events = ask(sim, "ATE0")
    assert events[0] == Echo("ATE0") and isinstance(events[1], Response)
    assert ask(sim, "AT")[0].result.ok  # type: ignore[attr-defined]
    assert not any(isinstance(e, Echo) for e in ask(sim, "ATI"))


def test_an_injected_sms_is_stored_announced_and_read() -> None:
    sim = SimulatedModem()
    set_up(sim)
    assert sim.inject("+61400000001", "#FHEAD 230", WHEN) == 1
    [urc] = AtReader().feed(sim.take_output())
    assert urc == Urc("+CMTI", '+CMTI: "SM",1')
    [response] = ask(sim, "AT+CMGR=1")
    assert isinstance(response, Response)
    [sms] = response.messages
    assert (sms.number, sms.text, sms.timestamp, sms.status) == (
        "+61400000001",
        "#FHEAD 230",
        WHEN,
        "REC UNREAD",
    )
    assert sim.store[1].status == "REC READ"
    assert ask(sim, "AT+CMGD=1")[0].result.ok  # type: ignore[attr-defined]
    assert sim.store == {}


def test_a_full_store_rejects_messages_and_writes() -> None:
    sim = SimulatedModem(capacity=2)
    set_up(sim)
    assert [sim.inject("+614", str(i)) for i in range(3)] == [1, 2, None]
    assert sim.rejected == [("+614", "2")]
    assert len(AtReader().feed(sim.take_output())) == 2  # two +CMTI, none for the third
    reader = AtReader()
    reader.start('AT+CMGW="+614"')
    sim.receive(b'AT+CMGW="+614"\r')
    assert reader.feed(sim.take_output()) == [Prompt()]
    sim.receive(b"draft\x1a")
    [response] = reader.feed(sim.take_output())
    assert (response.result.kind, response.result.code) == ("+CMS ERROR", 322)  # type: ignore[union-attr]
    assert ask(sim, "AT+CPMS?")[0].lines == ('+CPMS: "SM",2,2,"SM",2,2,"SM",2,2',)  # type: ignore[attr-defined]


def test_send_records_the_text_and_errors_are_one_shot() -> None:
    sim = SimulatedModem()
    set_up(sim)
    sim.faults.send_error = 332
    for expected in ("+CMS ERROR", "OK"):
        reader = AtReader()
        reader.start('AT+CMGS="+61400000001"')
        sim.receive(b'AT+CMGS="+61400000001"\r')
        assert reader.feed(sim.take_output()) == [Prompt()]
        sim.receive(b"\x00 home\x1a")  # GSM-7 '@' is 0x00
        [response] = reader.feed(sim.take_output())
        assert response.result.kind == expected  # type: ignore[union-attr]
    assert [(s.text, s.reference) for s in sim.sent] == [("@ home", 1)]


def test_a_reset_keeps_the_store_and_forgets_the_settings() -> None:
    clock = Clock()
    sim = SimulatedModem(clock=clock)
    set_up(sim)
    sim.inject("+614", "kept", WHEN)
    sim.take_output()
    sim.reset(boot_s=2.0)
    sim.receive(b"AT\r")  # ignored while it boots
    assert sim.take_output() == b""
    clock.now += 2.0
    events = AtReader().feed(sim.take_output())
    assert [e.text for e in events] == list(POWER_UP_BURST)  # type: ignore[attr-defined]
    assert sim.echo and not sim.text_mode and sim.cnmi_mt == 0
    assert sim.store[1].text == "kept"


def test_slow_answers_are_due_later_and_keep_their_order() -> None:
    clock = Clock()
    sim = SimulatedModem(clock=clock)
    sim.faults.delay_s = 1.0
    sim.receive(b"AT\r")
    assert sim.take_output() == b"AT\r"  # the echo is immediate
    clock.now += 1.0
    assert sim.take_output() == b"\r\nOK\r\n"


def test_scts_writes_the_zone_in_quarter_hours() -> None:
    assert scts(WHEN) == "26/11/23,04:05:00+00"
    local = datetime.fromisoformat("2026-11-23T14:05:00+10:00")
    assert scts(local) == "26/11/23,14:05:00+40"


def test_status_queries_and_delete_all() -> None:
    sim = SimulatedModem()
    set_up(sim)
    sim.inject("+614", "one", WHEN)
    sim.inject("+614", "two", WHEN)
    sim.take_output()
    answers = {c: ask(sim, c)[-1] for c in ("AT+CSQ", "AT+CREG?", "AT+CNMI?", "ATI")}
    assert answers["AT+CSQ"].lines == ("+CSQ: 21,99",)  # type: ignore[attr-defined]
    assert answers["AT+CREG?"].lines == ("+CREG: 0,1",)  # type: ignore[attr-defined]
    assert answers["AT+CNMI?"].lines == ("+CNMI: 2,1,0,0,0",)  # type: ignore[attr-defined]
    assert answers["ATI"].lines[0] == "Shoreside"  # type: ignore[attr-defined]
    assert ask(sim, "AT+CMGD=1,4")[-1].result.ok  # type: ignore[attr-defined]
    assert sim.store == {}
    assert ask(sim, "AT+BOGUS")[-1].result.kind == "ERROR"  # type: ignore[attr-defined]
