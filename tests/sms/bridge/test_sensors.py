"""The sensor manager's I/O over real UDP sockets: the subscriber against the stand-in for the
board's data servers (docs/wave-glider.md), and the latest readings (sms/bridge/sensors.py)."""

from __future__ import annotations

import dataclasses
import socket
import time
from collections.abc import Callable, Iterator

import pytest

from sms.bridge.records import RecordTable
from sms.bridge.sensor_standin import CAPTURED, RecordServer
from sms.bridge.sensors import LatestReadings, SensorSubscriber
from sms.level2.codec import Address
from sms.level2.payload import SensorState

STASIS = RecordTable.load().records["stasis"]
VALUES = {**CAPTURED, "humidity_pct": 35.5, "leak2": 1.0}


def poll_until(
    subscriber: SensorSubscriber, condition: Callable[[], bool], limit_s: float = 5
) -> bool:
    deadline = time.monotonic() + limit_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        subscriber.poll(0.05)
    return True


@pytest.fixture
def server() -> Iterator[RecordServer]:
    # port 0: any free port; the subscriber is given the layout with that port
    board = RecordServer(STASIS, lambda: VALUES, port=0, period_s=0.05).start()
    yield board
    board.stop()


def subscriber_for(server: RecordServer, readings: LatestReadings, **kw: float) -> SensorSubscriber:
    layout = dataclasses.replace(STASIS, port=server.port)
    return SensorSubscriber("127.0.0.1", [layout], readings, **kw)  # type: ignore[arg-type]


def test_it_subscribes_and_its_readings_reach_the_status_block(server: RecordServer) -> None:
    state = SensorState()
    readings = LatestReadings(state)
    with subscriber_for(server, readings) as subscriber:
        assert poll_until(subscriber, lambda: subscriber.stats.records >= 2)
    assert server.subscriptions == 1
    assert readings.snapshot() == VALUES
    block = state.block(Address(0, 1), queued=False)
    # §8.4: the capture's bytes (21 °C, 100 kPa); 35.5 % rounds to 36
    assert (block.humidity_temp_c, block.humidity_pct, block.pressure_kpa) == (21, 36, 100)
    assert (block.leak1, block.leak2) == (0, 1)


def test_garbage_and_short_datagrams_are_counted_and_dropped(server: RecordServer) -> None:
    readings = LatestReadings()
    with subscriber_for(server, readings) as subscriber:
        assert poll_until(subscriber, lambda: subscriber.stats.records >= 1)
        server.send_raw(b"\xff" * 40)
        server.send_raw(STASIS.encode(VALUES)[:5])
        assert poll_until(subscriber, lambda: sum(subscriber.stats.dropped.values()) == 2)
        assert poll_until(subscriber, lambda: subscriber.stats.records >= 3)
    assert dict(subscriber.stats.dropped) == {"header": 1, "short": 1}
    assert readings.snapshot() == VALUES


def test_datagrams_from_another_host_are_not_readings(server: RecordServer) -> None:
    readings = LatestReadings()
    with subscriber_for(server, readings) as subscriber:
        assert poll_until(subscriber, lambda: subscriber.stats.records >= 1)
        stream_port = subscriber._streams[0].sock.getsockname()[1]
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as stranger:
            stranger.bind(("127.0.0.2", 0))
            stranger.sendto(STASIS.encode({"leak1": 9.0}), ("127.0.0.1", stream_port))
        assert poll_until(subscriber, lambda: subscriber.stats.foreign == 1)
    assert readings.snapshot()["leak1"] == 0.0


def test_it_subscribes_again_when_the_board_forgets_it(server: RecordServer) -> None:
    readings = LatestReadings()
    with subscriber_for(server, readings, silence_s=0.3) as subscriber:
        assert poll_until(subscriber, lambda: subscriber.stats.records >= 1)
        server.subscriber = None  # the board rebooted: it sends to nobody
        assert poll_until(subscriber, lambda: server.subscriptions >= 2)
        heard = subscriber.stats.records
        assert poll_until(subscriber, lambda: subscriber.stats.records > heard)


def test_the_last_address_to_contact_the_board_gets_the_data(server: RecordServer) -> None:
    first, second = LatestReadings(), LatestReadings()
    with subscriber_for(server, first) as one, subscriber_for(server, second) as two:
        assert poll_until(one, lambda: one.stats.records >= 1)
        assert poll_until(two, lambda: two.stats.records >= 1)
        assert server.subscriber == ("127.0.0.1", two._streams[0].sock.getsockname()[1])


def test_a_stale_reading_is_forgotten_and_the_block_says_unknown() -> None:
    now = [100.0]
    state = SensorState()
    readings = LatestReadings(state, max_age_s=60, clock=lambda: now[0])
    readings.update({"pressure_kpa": 100.0, "water_temp_c": 18.5})
    now[0] += 30
    readings.update({"water_temp_c": 18.7})
    now[0] += 31
    assert readings.snapshot() == {"water_temp_c": 18.7}
    assert state.pressure_kpa is None
