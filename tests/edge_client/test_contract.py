"""The boat–shore contract (edge_client/contract/): one table each, pinned to ArduPilot's own.

The numbers are spelled in the contract so that it stays pure; pymavlink (which the boat runs)
carries MAVLink's and ArduPilot's definitions, so a typo or a renumbering fails here.
"""

from __future__ import annotations

import datetime as dt
import importlib.util
import inspect
import os
import re
from pathlib import Path

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as apm  # noqa: E402

from edge_client import mission as edge_mission  # noqa: E402
from edge_client.contract import fix as fix_shape  # noqa: E402
from edge_client.contract.kinds import ROVER_MODE_INITIALISING, ROVER_MODE_NAMES, ROVER_MODES  # noqa: E402
from edge_client.contract.mavcmd import MavCmd  # noqa: E402
from edge_client.contract.status import FINAL, OPEN, UNFINISHED, Status  # noqa: E402


@pytest.mark.parametrize("command", list(MavCmd), ids=lambda c: c.name)
def test_mav_cmd_numbers_are_mavlinks(command: MavCmd) -> None:
    assert getattr(apm, f"MAV_CMD_{command.name}") == command
    assert apm.enums["MAV_CMD"][command].name == f"MAV_CMD_{command.name}"


@pytest.mark.parametrize("name", ROVER_MODES)
def test_rover_modes_are_ardupilots(name: str) -> None:
    assert getattr(apm, f"ROVER_MODE_{name}") == ROVER_MODES[name]


def test_the_boot_mode_is_ardupilots_and_every_number_has_one_name() -> None:
    assert apm.ROVER_MODE_INITIALIZING == ROVER_MODE_INITIALISING
    assert ROVER_MODE_NAMES[ROVER_MODE_INITIALISING] == "INITIALISING"
    assert len(ROVER_MODE_NAMES) == len(ROVER_MODES) + 1


def test_the_status_groups_cover_every_status_once() -> None:
    assert FINAL | UNFINISHED == set(Status) and not FINAL & UNFINISHED
    assert set(OPEN) <= UNFINISHED and Status.ACKNOWLEDGED in UNFINISHED


def test_no_copy_of_the_tables_is_left_on_the_boat() -> None:
    assert importlib.util.find_spec("edge_client.catalog") is None  # the boat's old copy
    assert edge_mission.MAV_CMD_NAV_WAYPOINT is MavCmd.NAV_WAYPOINT


def test_the_api_schema_of_a_fix_is_the_contracts_shape() -> None:
    """FixIn (the schema) once let any battery_v through while the parser kept 0–1000."""
    from telemetry.api.boat import FixIn  # a DRF serializer: imported here, with the server

    fields = FixIn().fields
    assert tuple(fields) == fix_shape.FIELDS
    for name, (lo, hi) in fix_shape.RANGES.items():
        assert (fields[name].min_value, fields[name].max_value) == (lo, hi), name
        assert fields[name].required == (name in fix_shape.REQUIRED), name


def test_the_parser_takes_its_fields_and_ranges_from_the_contract() -> None:
    from telemetry.parsing import V1_FIELDS, FixErrors, parse_fix

    assert V1_FIELDS == set(fix_shape.FIELDS)
    now = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)
    for name, (lo, hi) in fix_shape.RANGES.items():
        fix = {"time": now.isoformat(), "lat": 0, "lon": 0, name: hi}
        assert getattr(parse_fix(fix, now=now), name) in (hi, hi % 360)
        assert getattr(parse_fix({**fix, name: lo}, now=now), name) == lo
        with pytest.raises(FixErrors):
            parse_fix({**fix, name: hi + 1}, now=now)
        with pytest.raises(FixErrors):
            parse_fix({**fix, name: lo - 1}, now=now)


def test_the_parser_takes_a_positions_range_from_the_contract(monkeypatch) -> None:
    """Narrow the contract's latitude: the parser follows (it spelled 90 and 180 itself)."""
    from telemetry.parsing import FixErrors, parse_fix

    now = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)
    monkeypatch.setitem(fix_shape.RANGES, "lat", (-80, 80))
    with pytest.raises(FixErrors, match="between -80 and 80"):
        parse_fix({"time": now.isoformat(), "lat": 85, "lon": 0}, now=now)


def test_the_ack_schemas_statuses_are_the_contracts() -> None:
    from drf_spectacular.generators import SchemaGenerator

    from edge_client.contract.status import ACK_STATUSES

    components = SchemaGenerator().get_schema(public=True)["components"]["schemas"]
    assert components["AckStatusEnum"]["enum"] == [str(s) for s in ACK_STATUSES]


def test_the_boat_writes_only_fields_of_the_contract() -> None:
    from edge_client.vehicle import VehicleState

    src = inspect.getsource(VehicleState)
    written = set(re.findall(r'fix\["(\w+)"\]', src))
    assert written and written <= set(fix_shape.FIELDS)


def test_the_servers_batch_answer_settles_the_boats_outbox() -> None:
    from edge_client.contract.batch import KEYS, BatchAnswer
    from edge_client.outbox import settle_fix_batch
    from telemetry.services import IngestResult

    answer = BatchAnswer(accepted=2, duplicates=1)
    answer.reject(3, {"lat": "must be between -90 and 90"})
    assert tuple(answer.as_dict()) == KEYS
    settled = settle_fix_batch([10, 11, 12, 13], answer.as_dict())
    assert settled.remove == (10, 11, 12, 13) and settled.rejected == (
        (13, answer.rejected[0]["errors"]),
    )
    assert IngestResult is BatchAnswer  # the telemetry upload answers the same shape


def test_every_batch_uploads_schema_is_the_contracts_answer() -> None:
    from drf_spectacular.generators import SchemaGenerator

    from edge_client.contract.batch import KEYS
    from edge_client.contract.exchange import COMMANDS_KEY, ETAG_KEY

    components = SchemaGenerator().get_schema(public=True)["components"]["schemas"]
    for name in ("CommandReportResult", "SmsUploadResult"):
        assert tuple(components[name]["properties"]) == KEYS, name
    # The telemetry answer: the contract's, then the command list's exchange when asked for.
    assert set(components["IngestResult"]["properties"]) == {*KEYS, ETAG_KEY, COMMANDS_KEY}
    assert set(components["IngestResult"]["required"]) == set(KEYS)


def test_backoff_doubles_up_to_its_cap() -> None:
    from edge_client.contract.backoff import after_failures, doubled

    assert [doubled(d, cap=30.0) for d in (1.0, 8.0, 16.0, 30.0)] == [2.0, 16.0, 30.0, 30.0]
    assert doubled(1e6) == 2e6  # uncapped by default
    assert [after_failures(5.0, n, cap=120.0) for n in (0, 1, 3, 5)] == [5.0, 10.0, 40.0, 120.0]
    assert after_failures(0.5, 10**6, cap=1e9) == 0.5 * 2**6  # at most six doublings


def test_every_list_of_a_fixs_fields_is_the_contracts() -> None:
    """The exports' columns, the fixes API and the fleet's last fix read the wire shape
    rather than spell it again (it was written out in nine places)."""
    from telemetry import sql
    from telemetry.api import export, views
    from vessels.api.views import LAST_FIX_FIELDS

    assert export.COLUMNS is fix_shape.FIELDS and LAST_FIX_FIELDS is fix_shape.FIELDS
    assert sql.EXPORT_NUMBERS is fix_shape.NUMBERS
    assert fix_shape.NUMBERS == ("lat", "lon", "heading_deg", "speed_mps", "battery_v")
    fields = views.FixSerializer.Meta.fields
    assert [name for name in fields if name != "received_at"] == list(fix_shape.FIELDS)


@pytest.mark.parametrize("enum", ["MAV_CMD", "MAV_FRAME", "MAV_MISSION_RESULT"])
def test_mavlinks_names_are_pymavlinks_with_no_table_of_our_own(enum: str) -> None:
    from edge_client.contract import mavcmd

    named = {n: e.name for n, e in apm.enums[enum].items() if not e.name.endswith("_ENUM_END")}
    assert {n: mavcmd.name(enum, n) for n in named} == named
    assert mavcmd.name(enum, 12345) is None


def test_without_pymavlink_every_number_is_unnamed(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    from edge_client.contract import mavcmd
    from vessels.missionfiles import mavitems

    mavcmd._names.cache_clear()
    monkeypatch.setitem(sys.modules, "pymavlink.dialects.v20.ardupilotmega", None)
    try:
        assert mavcmd.name("MAV_CMD", 16) is None
        assert mavitems.command_name(16) == "MAV_CMD 16"
    finally:
        mavcmd._names.cache_clear()


def test_the_commands_a_mission_file_refuses_by_name_are_mavlinks() -> None:
    from vessels.missionfiles import mavitems

    known = {e.name for e in apm.enums["MAV_CMD"].values()}
    assert mavitems._FOR_AIRCRAFT | mavitems._CAMERA <= known
    assert mavitems.command_name(183) == "MAV_CMD_DO_SET_SERVO"
    assert edge_mission.result_name(4) == "MAV_MISSION_NO_SPACE"


def test_the_modes_that_need_a_position_are_one_table_on_the_boat_and_in_the_simulator() -> None:
    from edge_client.contract.kinds import ROVER_POSITION_MODES
    from edge_client.executor import POSITION_MODES as BOAT
    from edge_client.sim.rover import POSITION_MODES as SIM

    assert BOAT is ROVER_POSITION_MODES and SIM is ROVER_POSITION_MODES  # the sim lacked two
    assert ROVER_POSITION_MODES <= set(ROVER_MODES)


def test_the_bridges_and_the_rebuild_loops_backoffs_are_the_contracts() -> None:
    """The same waits as the doublings they replace, and no overflow after a long outage."""
    from sms.bridge.process import HOUSEKEEPING_RETRY_MAX_S, housekeeping_retry_s
    from telemetry.management.commands.rebuild_track_overview import (
        RETRY_FIRST_S,
        RETRY_MAX_S,
        retry_delay,
    )

    for n in range(1, 200):
        assert retry_delay(n) == min(RETRY_FIRST_S * 2.0 ** (n - 1), RETRY_MAX_S)
        for tick in (0.05, 1.0):
            cap = max(tick, HOUSEKEEPING_RETRY_MAX_S)
            assert housekeeping_retry_s(tick, n) == min(tick * 2.0 ** (n - 1), cap)
    assert retry_delay(10**6) == RETRY_MAX_S  # 2 ** (10**6 - 1) seconds would not fit a float


# A doubling written out: `x * 2 ** n`, `2.0 ** n`, `*= 2`, `delay * 2`.
DOUBLING = re.compile(r"\* ?2(\.0)? ?\*\*|\b2(\.0)? ?\*\* ?\(?(min|fail|attempt|n\b)|\*= ?2\b")


def test_no_retry_loop_doubles_its_wait_by_hand() -> None:
    """Every wait that doubles goes through edge_client.contract.backoff (four did not)."""
    root = Path(__file__).resolve().parents[2]
    found = [
        f"{path.relative_to(root)}:{n}"
        for app in ("edge_client", "sms", "telemetry", "commands", "vessels", "fleet", "operators")
        for path in sorted((root / app).rglob("*.py"))
        if "contract" not in path.parts
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if DOUBLING.search(line.split("#")[0])
    ]
    # Doublings that are not waits: the series doubles a bucket width until the range fits.
    assert found == ["telemetry/series.py:39"]
