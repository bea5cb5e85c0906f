"""What the bridge tests share: a settable clock, and C&C frames addressed to the payload."""

from __future__ import annotations

import datetime as dt

import pytest

from sms.level2.bodies import AckNakQueued, StatusRequest
from sms.level2.codec import CC_MAIN, Address, Frame, MessageType

ME = Address(0x00, 0x01)  # PayloadConfig's default address (the real PIB's, §6)
T0 = dt.datetime(2026, 11, 24, 10, 0, tzinfo=dt.UTC)


class Clock:
    """``clock()`` is the time; tests move it with :meth:`advance`."""

    def __init__(self, start: dt.datetime = T0) -> None:
        self.now = start

    def __call__(self) -> dt.datetime:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += dt.timedelta(seconds=seconds)


@pytest.fixture
def clock() -> Clock:
    return Clock(dt.datetime.now(dt.UTC))


def request(msg_type: int, body: bytes = b"", tid: int = 0x19, **kw: object) -> Frame:
    return Frame.make(msg_type, body, tid=tid, src=CC_MAIN, dest=ME, **kw)  # type: ignore[arg-type]


def status(tid: int, fix: tuple[dt.datetime, float, float] | None = None) -> Frame:
    body = StatusRequest.with_fix(*fix) if fix else StatusRequest()
    return request(MessageType.REQUEST_STATUS, bytes(body), tid)


def queued(tid: int) -> Frame:
    return request(MessageType.REQUEST_QUEUED, b"", tid)


def result(code: int, tid: int) -> Frame:
    """§8.6 as captured: type 0x8041 (no ACK wanted) from the C&C main task."""
    return request(MessageType.ACK_NAK_QUEUED, bytes(AckNakQueued(code)), tid, no_ack=True)
