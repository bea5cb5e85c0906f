"""The payload state machine (§8–§10, §16 of docs/level2.md)."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sms.level2.bodies import (
    AckNakQueued,
    CommandPacket,
    EnumerationReply,
    ExtraInfo,
    InnerResponse,
    Nak,
    QueuedReply,
    StatusReply,
    StatusRequest,
)
from sms.level2.cfa import Capture
from sms.level2.codec import BROADCAST, CC_MAIN, Address, Frame, MessageType
from sms.level2.framing import decode_stream
from sms.level2.inner import InnerCommandTable
from sms.level2.payload import (
    CommandCompleted,
    CommandHandedOver,
    CommandResult,
    FixReceived,
    Ignored,
    MemoryCommandSource,
    PayloadConfig,
    PayloadMachine,
    PowerDown,
    PowerNotice,
    QueuedCommand,
    ResultWithoutCommand,
    SensorState,
)

from .test_codec import ACK_NAK_8041, h

ME = Address(0x00, 0x01)
REAL_PIB = PayloadConfig(
    address=ME,
    device_type=0x0001,
    serial="123456",
    description="Full PIB",
    poll_period_s=20,
    flags=0,
    firmware=(2, 1, 0x0180),
)
REAL_SENSORS = SensorState(0, 0, 21, 35, 21, 100)  # §8.4: the capture's readings


def machine(**config: object) -> PayloadMachine:
    return PayloadMachine(PayloadConfig(**config), source=MemoryCommandSource())  # type: ignore[arg-type]


def request(msg_type: int, body: bytes = b"", tid: int = 0x19, **kw: object) -> Frame:
    kw.setdefault("dest", ME)
    return Frame.make(msg_type, body, tid=tid, src=CC_MAIN, **kw)  # type: ignore[arg-type]


def status(tid: int = 0x19, **kw: object) -> Frame:
    return request(MessageType.REQUEST_STATUS, bytes(StatusRequest()), tid, **kw)


def queued(tid: int = 0x1A, **kw: object) -> Frame:
    return request(MessageType.REQUEST_QUEUED, b"", tid, **kw)


def result(code: int, tid: int = 0x46A, packet: bytes = b"", **kw: object) -> Frame:
    kw.setdefault("no_ack", True)
    return request(MessageType.ACK_NAK_QUEUED, bytes(AckNakQueued(code, packet)), tid, **kw)


# --- replaying the real captures -------------------------------------------------------------


def test_replay_of_the_power_up_capture_gives_the_real_boards_replies(
    captures: dict[str, Capture],
) -> None:
    capture = captures["OA_enum_first_2014Mar19.cfa"]
    real = {f.tid: f for f in decode_stream(capture.payload_to_cc)}
    pib = PayloadMachine(REAL_PIB, source=MemoryCommandSource(), sensors=REAL_SENSORS)
    for text in ("fhead 10", "fhead 20", "light on"):  # the real PIB had 3 messages queued
        pib.source.add(text)  # type: ignore[attr-defined]
    compared = 0
    for cc in decode_stream(capture.cc_to_payload):
        [ours] = pib.handle(cc)
        theirs = real[cc.tid]
        assert (ours.tid, ours.src, ours.msg_type) == (theirs.tid, theirs.src, theirs.msg_type)
        if cc.msg_type == MessageType.REQUEST_QUEUED:
            # Same flow (0x8040, 0x8040, 0x0040), but ours go to the command task, not console.
            assert (
                QueuedReply.from_bytes(ours.body).more == QueuedReply.from_bytes(theirs.body).more
            )
            assert ours.dest == Address(0x01, 0x00)
        elif cc.msg_type == MessageType.REQUEST_STATUS:
            assert len(bytes(ours)) == len(bytes(theirs)) == 31  # §7
            # byte-identical but for the pressure byte, which the real board varied (§8.4)
            assert ours.body[:-1] == theirs.body[:-1]
        else:
            assert bytes(ours) == bytes(theirs)  # the 61-byte enumeration reply, exactly
        compared += 1
    assert compared == 23


def test_replay_of_the_retry_capture_answers_every_attempt_identically(
    captures: dict[str, Capture],
) -> None:
    pib = PayloadMachine(REAL_PIB, source=MemoryCommandSource())
    answers: dict[int, set[bytes]] = {}
    for cc in decode_stream(captures["Responses.cfa"].cc_to_payload):
        [reply] = pib.handle(cc)
        answers.setdefault(cc.tid, set()).add(bytes(reply))
    assert sorted(answers) == [0x216F, 0x2171, 0x2173, 0x2175]
    assert all(len(replies) == 1 for replies in answers.values())


# --- enumerate and status -----------------------------------------------------------------------


def test_enumerate_on_broadcast_is_answered_with_the_configured_block() -> None:
    pib = machine(
        serial="42", description="Shoreside", poll_period_s=5, flags=ExtraInfo.COMMAND_ACK
    )
    [reply] = pib.handle(request(MessageType.ENUMERATE, h("01 00 01 00"), 0x17, dest=BROADCAST))
    assert reply.dest == CC_MAIN and reply.tid == 0x17 and reply.src == ME
    [device] = EnumerationReply.from_bytes(reply.body).devices
    assert device.serial == b"000042" and device.description == b"Shoreside".ljust(20)
    assert device.poll_period_s == 5 and device.flags == 0x08
    assert pib.enumerated


def test_status_reply_carries_the_sensor_state_with_zeros_for_unknown() -> None:
    sensors = SensorState(leak1=1, humidity_temp_c=-3, pressure_kpa=101.4, humidity_pct=400)
    pib = PayloadMachine(PayloadConfig(), source=MemoryCommandSource(), sensors=sensors)
    [reply] = pib.handle(status())
    block = StatusReply.from_bytes(reply.body).block
    assert (block.leak1, block.leak2, block.humidity_temp_c) == (1, 0, 0)
    assert (block.pressure_kpa, block.humidity_pct, block.pressure_temp_c) == (101, 255, 0)
    assert (block.task, block.board, block.version) == (0, 1, 0x0001)


def test_a_status_request_with_a_fix_becomes_the_latest_fix() -> None:
    pib = machine()
    when = datetime(2014, 4, 17, 22, 20, 43, tzinfo=UTC)
    body = bytes(StatusRequest.with_fix(when, 36.80278, -121.78812))
    pib.handle(request(MessageType.REQUEST_STATUS, body))
    assert pib.latest_fix is not None and pib.latest_fix.time == when
    assert pib.latest_fix.lat == pytest.approx(36.80278, abs=1e-6)
    assert pib.latest_fix.lon == pytest.approx(-121.78812, abs=1e-6)
    assert any(isinstance(n, FixReceived) for n in pib.notifications())
    pib.handle(status(tid=0x20))  # a no-fix request does not erase it
    assert pib.latest_fix.time == when


# --- queued commands ------------------------------------------------------------------------------


@pytest.mark.parametrize("count", [0, 1, 3])
def test_queued_message_flow(count: int) -> None:
    pib = machine()
    texts = ["fhead 230", "light on", "waypoint 3 -32.0345 115.3326"][:count]
    for text in texts:
        pib.source.add(text)  # type: ignore[attr-defined]
    [reply] = pib.handle(status())
    assert StatusReply.from_bytes(reply.body).block.queued == bool(count)
    sent = []
    tid = 0x1A
    while True:
        [reply] = pib.handle(queued(tid))
        if reply.msg_type == MessageType.NAK:
            assert Nak.from_bytes(reply.body) == Nak(0x0040, 0x02, b"\x00\x00")  # §8.5 ACFR
            break
        body = QueuedReply.from_bytes(reply.body)
        assert reply.dest == Address(0x01, 0x00)  # the C&C command task (§8.5)
        assert body.data[:2] == b"\x01\x00"  # command format 1 (§11.1)
        sent.append(CommandPacket.from_bytes(body.data[2:]))
        tid += 1
        if not body.more:
            break
    assert [p.value for p in sent] == [0x0008, 0x2002, 0x8000][:count]
    [reply] = pib.handle(status(tid=0x30))
    assert not StatusReply.from_bytes(reply.body).block.queued
    assert pib.awaiting_result == [f"cmd-{i}" for i in range(1, count + 1)]


def test_empty_queue_can_stay_silent_like_goby() -> None:
    assert machine(nak_empty_queue=False).handle(queued()) == []


def test_a_retried_request_is_answered_identically_and_hands_over_once() -> None:
    pib = machine()
    source: MemoryCommandSource = pib.source  # type: ignore[assignment]
    source.add("fhead 10")
    source.add("fhead 20")
    first = pib.handle(queued(0x1A))
    assert pib.handle(queued(0x1A)) == first  # §10: same tid → same answer
    assert pib.handle(queued(0x1A)) == first
    second = pib.handle(queued(0x1B))
    assert second != first
    assert source.handed_over == ["cmd-1", "cmd-2"]
    handovers = [n for n in pib.notifications() if isinstance(n, CommandHandedOver)]
    assert [(n.ident, n.tid) for n in handovers] == [("cmd-1", 0x1A), ("cmd-2", 0x1B)]


def test_a_new_enumeration_forgets_earlier_answers() -> None:
    pib = machine()
    enumerate_ = request(MessageType.ENUMERATE, h("01 00 01 00"), 0x17, dest=BROADCAST)
    pib.handle(enumerate_)
    first = pib.handle(status(0x18))
    pib.handle(enumerate_)  # the C&C rebooted: same first tid, same bytes
    pib.source.add("hold")  # type: ignore[attr-defined]
    # a rebooted C&C counting from the same tid again gets a fresh answer
    assert pib.handle(status(0x18)) != first


def test_a_retried_status_request_keeps_its_first_answer() -> None:
    pib = machine()
    first = pib.handle(status(0x40))
    pib.source.add("hold")  # type: ignore[attr-defined]
    assert pib.handle(status(0x40)) == first  # the retry: same tid, same bytes
    [fresh] = pib.handle(status(0x41))
    assert StatusReply.from_bytes(fresh.body).block.queued


class ListSource:
    """A command source that is not the in-memory one (the bridge's is database-backed)."""

    def __init__(self, *queued: QueuedCommand) -> None:
        self.queued = list(queued)
        self.completed: list[CommandResult] = []

    def pending_count(self) -> int:
        return len(self.queued)

    def take_next(self) -> QueuedCommand | None:
        return self.queued.pop(0) if self.queued else None

    def complete(self, result: CommandResult) -> None:
        self.completed.append(result)


def test_the_machine_needs_a_command_source_from_its_caller() -> None:
    with pytest.raises(TypeError, match="source"):
        PayloadMachine(PayloadConfig())  # type: ignore[call-arg]


def test_commands_come_from_and_results_go_to_the_callers_source() -> None:
    command = QueuedCommand("db-41", InnerCommandTable.load().parse("fhead 230"))
    source = ListSource(command)
    pib = PayloadMachine(PayloadConfig(), source=source)
    [answer] = pib.handle(status())
    assert StatusReply.from_bytes(answer.body).block.queued
    [handover] = pib.handle(queued())
    assert QueuedReply.from_bytes(handover.body).data == command.queued_data()
    pib.handle(result(0))
    assert [(r.ident, r.done) for r in source.completed] == [("db-41", True)]


# --- results --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("code", "done", "meaning"),
    [
        (0, True, "accepted"),
        (1, False, "unknown command"),
        (2, False, "invalid data"),
        (3, False, "unable to complete"),
        (4, False, "unknown format"),
        (9, False, "unknown response code 9"),
    ],
)
def test_every_response_code_becomes_a_result(code: int, done: bool, meaning: str) -> None:
    pib = machine()
    source: MemoryCommandSource = pib.source  # type: ignore[assignment]
    source.add("fhead 230", ident="sms-7")
    pib.handle(queued())
    assert pib.handle(result(code)) == []  # 0x8041: no ACK wanted, none sent
    outcome = source.results["sms-7"]
    assert (outcome.done, outcome.meaning, outcome.code) == (done, meaning, code)
    assert any(isinstance(n, CommandCompleted) for n in pib.notifications())
    assert pib.awaiting_result == []


def test_results_are_matched_to_commands_in_order_and_keep_the_response() -> None:
    pib = machine()
    source: MemoryCommandSource = pib.source  # type: ignore[assignment]
    source.add("fhead 1")
    source.add("fhead 2")
    pib.handle(queued(0x1A))
    pib.handle(queued(0x1B))
    real = Frame.from_bytes(h(ACK_NAK_8041))  # addressed to 10/00 as on the real line (§8.6)
    pib.handle(real)
    pib.handle(result(2, tid=0x46B))
    assert source.results["cmd-1"].done
    response = source.results["cmd-1"].response
    assert isinstance(response, InnerResponse) and len(response.data) == 35
    assert source.results["cmd-2"].meaning == "invalid data"


def test_a_result_that_wants_an_ack_gets_one() -> None:
    pib = machine()
    [ack] = pib.handle(result(0, no_ack=False))
    assert ack.msg_type == MessageType.ACK and ack.body == h("41 00 01 00")
    assert any(isinstance(n, ResultWithoutCommand) for n in pib.notifications())


# --- what must not be answered -------------------------------------------------------------------


@pytest.mark.parametrize(
    "frame",
    [
        status(dest=Address(0x00, 0x02)),  # another board
        status(dest=Address(0x05, 0x01)),  # another task on our board
        status(dest=BROADCAST),  # status is never broadcast
        queued(dest=Address(0x01, 0x01)),
        result(0, dest=Address(0x05, 0x00), no_ack=False),
        request(0x0077, b"\x01"),  # unknown type
        request(MessageType.ENUMERATE, h("01 00 01 00"), dest=Address(0x00, 0x02)),
        status(no_ack=True),  # §5: bit 15 set, no ACK requested
        queued(no_ack=True),
        request(MessageType.ACK, h("22 00")),
        request(MessageType.NAK, h("22 00 01")),
        request(MessageType.CC_TELEMETRY, b"\x01" + bytes(10), dest=BROADCAST),
        request(MessageType.SEND_FORWARD, h("01 01 00"), dest=BROADCAST),
        request(MessageType.REQUEST_STATUS, b"\x00\x01"),  # body too short
    ],
)
def test_frames_that_must_not_be_answered(frame: Frame) -> None:
    pib = machine()
    pib.source.add("fhead 1")  # type: ignore[attr-defined]
    assert pib.handle(frame) == []
    assert pib.source.pending_count() == 1


def test_ignored_frames_are_reported_for_the_log() -> None:
    pib = machine()
    pib.handle(status(dest=Address(0x00, 0x02)))
    [note] = pib.notifications()
    assert isinstance(note, Ignored) and "00/02" in note.reason


def test_a_no_ack_queued_request_takes_no_command() -> None:
    pib = machine()
    source: MemoryCommandSource = pib.source  # type: ignore[assignment]
    source.add("fhead 1")
    assert pib.handle(queued(no_ack=True)) == []
    # Its answer could not be sent, so the command stays queued for the next request.
    assert source.handed_over == [] and source.pending_count() == 1


# --- power notices (layout unknown: synthetic frames) ----------------------------------------


def test_power_notices_are_logged_and_raise_power_down() -> None:
    pib = machine()
    notice = request(MessageType.POWER, h("01 02 03"), dest=BROADCAST)
    assert pib.handle(notice) == []
    notes = pib.notifications()
    assert PowerNotice(h("01 02 03")) in notes and PowerDown(h("01 02 03")) in notes


def test_which_power_notices_mean_power_down_is_configurable() -> None:
    pib = machine(is_power_down=lambda body: body[:1] == b"\x00")
    pib.handle(request(MessageType.POWER, h("01"), dest=BROADCAST))
    pib.handle(request(MessageType.POWER, h("00 05"), dest=ME, tid=0x20))
    downs = [n for n in pib.notifications() if isinstance(n, PowerDown)]
    assert downs == [PowerDown(h("00 05"))]


# --- robustness ---------------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(
        [0x0000, 0x0001, 0x0010, 0x0015, 0x0022, 0x0024, 0x0030, 0x0040, 0x0041, 0x7FFF]
    ),
    st.binary(max_size=60),
    st.sampled_from([ME, BROADCAST, Address(0x10, 0x00), Address(0x00, 0x02)]),
    st.booleans(),
    st.integers(0, 0xFFFF),
)
def test_any_frame_is_handled_without_an_exception(
    msg_type: int, body: bytes, dest: Address, no_ack: bool, tid: int
) -> None:
    pib = machine()
    pib.source.add("fhead 1")  # type: ignore[attr-defined]
    frame = Frame.make(msg_type, body, tid=tid, dest=dest, src=CC_MAIN, no_ack=no_ack)
    replies = pib.handle(frame)
    assert all(isinstance(r, Frame) and r.tid == tid for r in replies)
    if no_ack:
        assert replies == []
    pib.notifications()
