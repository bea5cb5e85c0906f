"""The mission protocol state machines, driven by hand with lost and repeated messages."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge_client.mission import (
    EXCHANGE_TIMEOUT_S,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_JUMP,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAX_RETRIES,
    ROVER_MAX_HOLD_S,
    MissionDownload,
    MissionError,
    MissionItem,
    MissionUpload,
    Out,
    WaypointNumbers,
    build_mission,
    hold_seconds,
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


HOME = (-31.94, 115.85)
WP, SPEED, JUMP, RTL = (MAV_CMD_NAV_WAYPOINT, MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_DO_JUMP,
                        MAV_CMD_NAV_RETURN_TO_LAUNCH)  # fmt: skip


def shape(mission: list[MissionItem]) -> list[tuple]:
    """(command, param1, param2) of each item after home: what the mapping decides."""
    return [(i.command, i.param1, i.param2) for i in mission[1:]]


def test_home_comes_first_in_the_global_frame_and_items_are_numbered_in_order():
    m = build_mission(HOME, WPS)
    assert [i.seq for i in m] == [0, 1, 2]
    assert (m[0].command, m[0].x, m[0].y, m[0].frame) == (WP, -319400000, 1158500000, 0)
    assert (m[1].x, m[1].y) == (-319500000, 1158600000)


def test_a_waypoint_carries_its_hold_in_param1_and_its_radius_in_param2():
    assert shape(build_mission(HOME, WPS)) == [(WP, 5.0, 3.0), (WP, 0.0, 0.0)]
    assert build_mission(HOME, WPS)[1].frame == MAV_FRAME_GLOBAL_RELATIVE_ALT


def test_a_speed_change_goes_just_before_its_waypoint_and_only_where_asked():
    items = [{**WPS[0], "speed_mps": 1.5}, WPS[1], {**WPS[1], "speed_mps": 3}]
    m = build_mission(HOME, items)
    assert shape(m) == [(SPEED, 1.0, 1.5), (WP, 5.0, 3.0), (WP, 0.0, 0.0), (SPEED, 1.0, 3.0),
                        (WP, 0.0, 0.0)]  # fmt: skip
    # A DO command has no position: zeros in the global frame, as ArduPilot hands it back.
    assert (m[1].x, m[1].y, m[1].z, m[1].frame, m[1].param3, m[1].param4) == (0, 0, 0, 0, 0, 0)


def test_a_hold_is_kept_in_whole_seconds_rounded_up_so_none_is_lost():
    assert [hold_seconds(h) for h in (0, 0.1, 1, 1.5, 2.0)] == [0, 1, 1, 2, 2]
    assert hold_seconds(ROVER_MAX_HOLD_S) == ROVER_MAX_HOLD_S
    with pytest.raises(MissionError, match="longer than ArduPilot Rover can hold"):
        hold_seconds(ROVER_MAX_HOLD_S + 0.5)
    with pytest.raises(MissionError, match="item 1: hold 86400 s"):
        build_mission(HOME, [WPS[0], {**WPS[1], "hold_s": 86400}])


def test_stop_adds_nothing_loop_jumps_back_to_item_1_forever_return_home_ends_with_rtl():
    assert shape(build_mission(HOME, WPS, end="stop"))[-1] == (WP, 0.0, 0.0)
    loop = build_mission(HOME, WPS, end="loop")[-1]
    assert (loop.seq, loop.command, loop.param1, loop.param2, loop.frame) == (3, JUMP, 1, -1, 0)
    home = build_mission(HOME, WPS, end="return_home")[-1]
    assert (home.seq, home.command, home.x, home.y, home.frame) == (3, RTL, 0, 0, MAV_FRAME_GLOBAL)
    with pytest.raises(MissionError, match="unknown mission end 'sink'"):
        build_mission(HOME, WPS, end="sink")


def test_a_loop_jumps_to_item_1_even_when_that_is_a_speed_change():
    m = build_mission(HOME, [{**WPS[0], "speed_mps": 2}, WPS[1]], end="loop")
    assert shape(m) == [(SPEED, 1.0, 2.0), (WP, 5.0, 3.0), (WP, 0.0, 0.0), (JUMP, 1.0, -1.0)]


def test_mavlink_items_map_back_to_the_operators_waypoint_numbers():
    wps = [{"lat": -31.9 - i / 1000, "lon": 115.8, "speed_mps": 2.0 if i in (0, 2) else None}
           for i in range(5)]  # fmt: skip
    items = build_mission((-31.9, 115.8), wps, end="return_home")
    # home, speed, wp1, wp2, speed, wp3, wp4, wp5, RTL
    assert [i.command for i in items] == [16, 178, 16, 16, 178, 16, 16, 16, 20]
    numbers = WaypointNumbers.of(items)
    assert numbers.count == 5
    assert [numbers.number(i.seq) for i in items] == [None, 1, 1, 2, 3, 3, 4, 5, None]
    assert numbers.describe(7) == "waypoint 5 of 5"  # MAVLink's 7, the operator's 5
    assert numbers.describe(4) == "waypoint 3 of 5"  # the speed change on the leg to 3
    assert numbers.describe(8) == "item 8" and numbers.describe(None) == "item None"


def test_the_largest_mission_the_catalog_allows_is_built_whole():
    items = [{"lat": -31.9 - i / 1e4, "lon": 115.8, "hold_s": 1, "radius_m": 2, "speed_mps": 2}
             for i in range(500)]  # fmt: skip
    m = build_mission(HOME, items, end="return_home")
    assert len(m) == 1 + 2 * 500 + 1 and [i.seq for i in m] == list(range(len(m)))
    assert [i.command for i in m[1:5]] == [SPEED, WP, SPEED, WP] and m[-1].command == RTL


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
