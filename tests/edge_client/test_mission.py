"""The mission protocol state machines, driven by hand with lost and repeated messages."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from edge_client.mission import (
    EXCHANGE_TIMEOUT_S,
    MAV_CMD_DO_JUMP,
    MAV_CMD_NAV_WAYPOINT,
    MAX_RETRIES,
    MissionDownload,
    MissionUpload,
    Out,
    build_mission,
    item_out,
)

WPS = [
    {"lat": -31.95, "lon": 115.86, "hold_s": 5, "radius_m": 3},
    {"lat": -31.96, "lon": 115.87, "hold_s": 0, "radius_m": 0},
]


def items():
    return build_mission((-31.94, 115.85), WPS)


def req(seq: int, old: bool = False):
    return ("MISSION_REQUEST" if old else "MISSION_REQUEST_INT", {"seq": seq, "mission_type": 0})


def ack(code: int = 0):
    return ("MISSION_ACK", {"type": code, "mission_type": 0})


def test_build_mission_puts_home_first_and_waypoint_params_in_place():
    m = build_mission((-31.94, 115.85), WPS, loop=True)
    assert [i.seq for i in m] == [0, 1, 2, 3]
    assert (m[0].x, m[0].y, m[0].command) == (-319400000, 1158500000, MAV_CMD_NAV_WAYPOINT)
    assert (m[1].param1, m[1].param2) == (5.0, 3.0)  # hold seconds, acceptance radius
    assert m[3].command == MAV_CMD_DO_JUMP and (m[3].param1, m[3].param2) == (1.0, -1.0)


def test_upload_answers_old_and_int_requests_with_item_int():
    m = items()
    up = MissionUpload(m)
    assert up.start(0.0) == [Out("MISSION_COUNT", {"count": 3})]
    assert up.handle(*req(0, old=True), 0.1) == [item_out(m[0])]  # ArduPilot Rover asks this way
    assert up.handle(*req(1), 0.2) == [item_out(m[1])]
    assert up.handle(*req(2, old=True), 0.3) == [item_out(m[2])]
    assert up.handle(*ack(0), 0.4) == []
    assert up.done and up.ok and up.result == 0


def test_a_repeated_request_is_answered_again():
    m = items()
    up = MissionUpload(m)
    up.start(0.0)
    up.handle(*req(0), 0.1)
    assert up.handle(*req(0), 0.5) == [item_out(m[0])]  # our item was lost on the way
    assert not up.done


def test_a_lost_count_is_resent_after_the_timeout():
    up = MissionUpload(items())
    first = up.start(0.0)
    assert up.poll(EXCHANGE_TIMEOUT_S - 0.01) == []
    assert up.poll(EXCHANGE_TIMEOUT_S + 0.01) == first


def test_a_lost_request_makes_us_resend_the_last_item():
    m = items()
    up = MissionUpload(m)
    up.start(0.0)
    up.handle(*req(0), 0.1)
    assert up.poll(0.1 + EXCHANGE_TIMEOUT_S + 0.01) == [item_out(m[0])]


def test_a_stale_accepted_ack_does_not_end_the_upload():
    up = MissionUpload(items())
    up.start(0.0)
    up.handle(*ack(0), 0.05)  # left over from an earlier upload
    assert not up.done
    up.handle(*req(0), 0.1)
    up.handle(*req(1), 0.2)
    up.handle(*req(2), 0.3)
    up.handle(*ack(0), 0.4)
    assert up.ok


def test_an_error_ack_fails_the_upload_with_its_name():
    up = MissionUpload(items())
    up.start(0.0)
    up.handle(*req(0), 0.1)
    up.handle(*ack(4), 0.2)
    assert up.done and not up.ok and up.result == 4
    assert "MAV_MISSION_NO_SPACE" in up.error


def test_other_mission_types_are_ignored():
    up = MissionUpload(items())
    up.start(0.0)
    assert up.handle("MISSION_REQUEST_INT", {"seq": 0, "mission_type": 1}, 0.1) == []


def test_silence_ends_in_a_cancel_after_the_retries():
    up = MissionUpload(items())
    up.start(0.0)
    now = 0.0
    sent = []
    for _ in range(MAX_RETRIES + 1):
        now += EXCHANGE_TIMEOUT_S + 0.01
        sent.append(up.poll(now))
    assert sent[:-1] == [[Out("MISSION_COUNT", {"count": 3})]] * MAX_RETRIES
    assert sent[-1] == [Out("MISSION_ACK", {"type": 15})]
    assert up.done and not up.ok and "retries" in up.error


def as_fields(out: Out) -> dict:
    return {**out.fields, "mission_type": 0}


def test_download_survives_lost_and_duplicated_items():
    m = items()
    down = MissionDownload()
    assert down.start(0.0) == [Out("MISSION_REQUEST_LIST")]
    assert down.handle("MISSION_COUNT", {"count": 3, "mission_type": 0}, 0.1) == [
        Out("MISSION_REQUEST_INT", {"seq": 0})
    ]
    down.handle("MISSION_ITEM_INT", as_fields(item_out(m[0])), 0.2)
    # item 1 is lost: the request is repeated after the per-item timeout
    assert down.poll(0.2 + 0.3) == [Out("MISSION_REQUEST_INT", {"seq": 1})]
    down.handle("MISSION_ITEM_INT", as_fields(item_out(m[1])), 0.6)
    down.handle("MISSION_ITEM_INT", as_fields(item_out(m[1])), 0.61)  # a duplicate: ignored
    out = down.handle("MISSION_ITEM_INT", as_fields(item_out(m[2])), 0.7)
    assert out == [Out("MISSION_ACK", {"type": 0})]
    assert down.ok and all(a.same_route(b) for a, b in zip(down.items, m, strict=True))


def test_download_accepts_the_float_mission_item():
    m = items()
    down = MissionDownload()
    down.start(0.0)
    down.handle("MISSION_COUNT", {"count": 1, "mission_type": 0}, 0.1)
    f = as_fields(item_out(m[0]))
    f.update(x=m[0].x / 1e7, y=m[0].y / 1e7)
    down.handle("MISSION_ITEM", f, 0.2)
    assert down.ok and down.items[0].same_route(m[0])


# -- property: any pattern of loss and duplication ends cleanly ------------------------------------


class Receiver:
    """A minimal autopilot side of an upload: requests items in order, re-requests on silence."""

    RETRY_S = 0.5

    def __init__(self) -> None:
        self.count: int | None = None
        self.items: list = []
        self.asked_at = 0.0
        self.done = False

    def handle(self, out: Out, now: float) -> list[tuple[str, dict]]:
        if out.type == "MISSION_COUNT":
            self.count, self.items, self.done = out.fields["count"], [], False
            return self._ask(now)
        if out.type == "MISSION_ITEM_INT" and self.count is not None and not self.done:
            if out.fields["seq"] != len(self.items):
                return self._ask(now)
            self.items.append(out.fields)
            if len(self.items) == self.count:
                self.done = True
                return [ack(0)]
            return self._ask(now)
        return []

    def poll(self, now: float) -> list[tuple[str, dict]]:
        if self.count is not None and not self.done and now - self.asked_at > self.RETRY_S:
            return self._ask(now)
        return []

    def _ask(self, now: float) -> list[tuple[str, dict]]:
        self.asked_at = now
        return [req(len(self.items), old=True)]


@settings(max_examples=60, deadline=None)
@given(
    n_waypoints=st.integers(1, 6),
    fate=st.lists(st.sampled_from(["ok", "ok", "ok", "drop", "dup"]), min_size=1, max_size=200),
)
def test_upload_with_any_loss_either_succeeds_with_every_item_or_gives_up(n_waypoints, fate):
    m = build_mission((-31.9, 115.8), [{"lat": -31.9 - i / 1e3, "lon": 115.8} for i in range(
        n_waypoints)])  # fmt: skip
    up, rx = MissionUpload(m), Receiver()
    fates = iter(fate)

    def deliver(messages: list) -> list:
        out = []
        for msg in messages:
            f = next(fates, "ok")
            out += [] if f == "drop" else [msg] * (2 if f == "dup" else 1)
        return out

    now = 0.0
    to_rx, to_up = deliver(up.start(now)), []
    for _ in range(2000):
        now += 0.05
        for msg in to_rx:
            to_up += deliver(rx.handle(msg, now))
        to_rx = []
        for msg_type, fields in to_up:
            to_rx += deliver(up.handle(msg_type, fields, now))
        to_up = deliver(rx.poll(now))
        to_rx += deliver(up.poll(now))
        if up.done:
            break
    assert up.done
    if up.ok:
        assert [f["seq"] for f in rx.items] == list(range(len(m)))
        assert [item_out(i).fields for i in m] == rx.items
