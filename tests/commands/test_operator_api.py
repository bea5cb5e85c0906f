"""Operator API (DESIGN §5): vessels, fixes (JSON pages and CSV), commands; docs and schema."""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Callable
from typing import Any

import pytest
from django.contrib.auth.models import User
from rest_framework.test import APIClient

from commands.lifecycle import Status
from commands.models import Command
from commands.services import command_ack, command_claim_open, command_enqueue
from telemetry.services import fix_ingest
from vessels.models import Vessel

VESSELS = "/api/v1/vessels/"
BASE = dt.datetime(2026, 11, 23, 8, 0, tzinfo=dt.UTC)


def fixes_url(slug: str = "spab") -> str:
    return f"/api/v1/vessels/{slug}/fixes/"


def commands_url(slug: str = "spab") -> str:
    return f"/api/v1/vessels/{slug}/commands/"


def cancel_url(uid: object) -> str:
    return f"/api/v1/commands/{uid}/cancel/"


def iso(when: dt.datetime) -> str:
    return when.isoformat().replace("+00:00", "Z")


@pytest.fixture
def track(vessel_a: Vessel) -> list[dt.datetime]:
    """Ten fixes of vessel A, a minute apart from 08:00, and one of vessel B."""
    times = [BASE + dt.timedelta(minutes=i) for i in range(10)]
    fix_ingest(
        vessel=vessel_a,
        records=[
            {"time": iso(t), "lat": -32 + i / 100, "lon": 115.7, "readings": {"t": i, "s": 35.5}}
            for i, t in enumerate(times)
        ],
    )
    return times


# --- the auth matrix, on every operator endpoint ---

Request = Callable[[APIClient, Command], Any]
ENDPOINTS: dict[str, Request] = {
    "vessel list": lambda c, cmd: c.get(VESSELS),
    "vessel detail": lambda c, cmd: c.get(f"{VESSELS}spab/"),
    "fixes": lambda c, cmd: c.get(fixes_url()),
    "fixes csv": lambda c, cmd: c.get(fixes_url() + "?format=csv"),
    "command list": lambda c, cmd: c.get(commands_url()),
    "command create": lambda c, cmd: c.post(
        commands_url(), {"kind": "hold", "params": {}}, format="json"
    ),
    "command cancel": lambda c, cmd: c.post(cancel_url(cmd.uid)),
}
OK = {"command create": 201}


@pytest.mark.parametrize("endpoint", list(ENDPOINTS))
def test_anonymous_is_refused(anonymous: APIClient, command_a: Command, endpoint: str) -> None:
    response = ENDPOINTS[endpoint](anonymous, command_a)
    assert response.status_code in (401, 403)
    assert response.json()["error"] == "not_authenticated"


@pytest.mark.parametrize("endpoint", list(ENDPOINTS))
def test_an_operator_without_permissions_is_refused(
    readonly: APIClient, command_a: Command, endpoint: str
) -> None:
    response = ENDPOINTS[endpoint](readonly, command_a)
    assert response.status_code == 403
    assert response.json() == {
        "error": "permission_denied",
        "detail": "You do not have permission to perform this action.",
    }
    assert Command.objects.count() == 1
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


@pytest.mark.parametrize("persona", ["boat_a", "boat_b", "revoked_boat"])
@pytest.mark.parametrize("endpoint", list(ENDPOINTS))
def test_boat_keys_are_refused_on_the_operator_api(
    request: pytest.FixtureRequest, command_a: Command, persona: str, endpoint: str
) -> None:
    response = ENDPOINTS[endpoint](request.getfixturevalue(persona), command_a)
    assert response.status_code == 403
    assert Command.objects.count() == 1
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


@pytest.mark.parametrize("persona", ["operator", "session_operator", "token_operator"])
@pytest.mark.parametrize("endpoint", list(ENDPOINTS))
def test_an_operator_with_permissions_is_served(
    request: pytest.FixtureRequest, command_a: Command, persona: str, endpoint: str
) -> None:
    client: APIClient = request.getfixturevalue(persona)  # test clients skip CSRF checks
    response = ENDPOINTS[endpoint](client, command_a)
    assert response.status_code == OK.get(endpoint, 200)


def test_a_session_post_needs_the_csrf_token(operator_user: User, command_a: Command) -> None:
    client = APIClient(enforce_csrf_checks=True)
    client.force_login(operator_user)
    response = client.post(cancel_url(command_a.uid))
    assert response.status_code == 403
    assert "CSRF" in response.json()["detail"]
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


# --- vessels ---


def test_it_lists_vessels_with_their_last_fix_and_state(
    operator: APIClient, vessel_a: Vessel, vessel_b: Vessel, glider: Vessel, track: Any
) -> None:
    body = operator.get(VESSELS).json()
    assert [v["slug"] for v in body] == ["spab", "spab-2", "glider"]  # by name
    spab = next(v for v in body if v["slug"] == "spab")
    assert spab["kind"] == "mavlink"
    assert spab["last_fix"]["time"] == "2026-11-23T08:09:00+00:00"
    assert spab["last_fix"]["lat"] == pytest.approx(-31.91)
    assert spab["last_fix_at"] == "2026-11-23T08:09:00Z"
    assert spab["status"] in {"reporting", "overdue"}
    other = next(v for v in body if v["slug"] == "spab-2")
    assert (other["status"], other["last_fix"]) == ("never seen", None)


def test_it_shows_one_vessel_by_slug(operator: APIClient, glider: Vessel) -> None:
    body = operator.get(f"{VESSELS}glider/").json()
    assert (body["slug"], body["name"], body["kind"]) == ("glider", "Wave Glider", "wave_glider")
    response = operator.get(f"{VESSELS}nope/")
    assert response.status_code == 404
    assert response.json()["error"] == "not_found"


def test_the_vessel_api_is_read_only(operator: APIClient, vessel_a: Vessel) -> None:
    # Refused by permission (no add/delete right) or by method: either way nothing changes.
    assert operator.post(VESSELS, {"slug": "x", "name": "X"}, format="json").status_code in (
        403,
        405,
    )
    assert operator.delete(f"{VESSELS}spab/").status_code in (403, 405)
    assert Vessel.objects.count() == 1
    assert Vessel.objects.filter(slug="spab").exists()


# --- fixes ---


def test_it_pages_fixes_in_time_order_with_a_cursor(operator: APIClient, track: list) -> None:
    seen: list[str] = []
    url: str | None = fixes_url() + "?page_size=4"
    pages = 0
    while url:
        body = operator.get(url).json()
        assert set(body) == {"next", "previous", "results"}
        seen += [f["time"] for f in body["results"]]
        url = body["next"]
        pages += 1
    assert pages == 3
    assert seen == [iso(t) for t in track]


def test_a_fix_carries_its_values(operator: APIClient, track: list) -> None:
    first = operator.get(fixes_url() + "?page_size=1").json()["results"][0]
    assert first["time"] == "2026-11-23T08:00:00Z"
    assert (first["lat"], first["lon"], first["readings"]) == (-32.0, 115.7, {"t": 0.0, "s": 35.5})
    assert first["heading_deg"] is None


@pytest.mark.parametrize(
    ("query", "expected"),
    [
        ("?from=2026-11-23T08:03:00Z&to=2026-11-23T08:06:00Z", [3, 4, 5]),
        ("?from=2026-11-23T08:08:00Z", [8, 9]),
        ("?to=2026-11-23T08:01:00Z", [0]),
        (f"?from={BASE.timestamp() + 540:.0f}", [9]),
        ("?from=2026-11-23T10:03:00%2B02:00&to=2026-11-23T08:05:00Z", [3, 4]),
        ("?from=2026-11-23T09:00:00Z", []),
    ],
)
def test_it_filters_fixes_by_time_range(
    operator: APIClient, track: list, query: str, expected: list[int]
) -> None:
    body = operator.get(fixes_url() + query).json()
    assert [f["readings"]["t"] for f in body["results"]] == expected


@pytest.mark.parametrize(
    ("query", "field"),
    [("?from=yesterday", "from"), ("?to=2026-11-23T08:00:00", "to"), ("?from=1", "from")],
)
def test_a_bad_time_range_is_a_400_naming_the_parameter(
    operator: APIClient, track: list, query: str, field: str
) -> None:
    response = operator.get(fixes_url() + query)
    assert response.status_code == 400
    body = response.json()
    assert body["error"] == "invalid"
    assert list(body["detail"]) == [field]


def test_only_the_named_vessels_fixes_are_listed(
    operator: APIClient, track: list, vessel_b: Vessel
) -> None:
    fix_ingest(vessel=vessel_b, records=[{"time": iso(BASE), "lat": 1, "lon": 1}])
    assert len(operator.get(fixes_url("spab-2")).json()["results"]) == 1
    assert len(operator.get(fixes_url()).json()["results"]) == 10
    assert operator.get(fixes_url("nope")).status_code == 404


def test_it_exports_fixes_as_csv(operator: APIClient, track: list) -> None:
    response = operator.get(
        fixes_url() + "?format=csv&from=2026-11-23T08:07:00Z&to=2026-11-23T08:09:00Z"
    )
    assert response.status_code == 200
    assert response["Content-Type"] == "text/csv"
    assert response["Content-Disposition"] == 'attachment; filename="spab-fixes.csv"'
    lines = b"".join(response.streaming_content).decode().splitlines()
    assert lines == [
        "recorded_at,lat,lon,heading_deg,speed_mps,battery_v,readings",
        "2026-11-23T08:07:00+00:00,-31.93,115.7,,,,s=35.5;t=7.0",
        "2026-11-23T08:08:00+00:00,-31.92,115.7,,,,s=35.5;t=8.0",
    ]


@pytest.mark.parametrize("name", ['=HYPERLINK("http://x")', "+1", "@SUM(A1)", "-x"])
def test_the_csv_export_never_starts_a_cell_with_a_formula(
    operator: APIClient, vessel_a: Vessel, name: str
) -> None:
    # Reading names come from the boat: one must not become a formula in the operator's
    # spreadsheet (CSV injection).
    fix_ingest(
        vessel=vessel_a,
        records=[{"time": "2026-11-23T08:00:00Z", "lat": 1.0, "lon": 2.0, "readings": {name: 1}}],
    )
    response = operator.get(fixes_url() + "?format=csv")
    cells = b"".join(response.streaming_content).decode().splitlines()[1].split(",", 6)
    assert cells[6].strip('"').startswith("'")
    assert cells[1:3] == ["1.0", "2.0"]


# --- commands ---


def test_it_lists_a_vessels_commands_newest_first_with_their_history(
    operator: APIClient, vessel_a: Vessel, vessel_b: Vessel
) -> None:
    old = command_enqueue(vessel=vessel_a, kind="arm", params={})
    new = command_enqueue(vessel=vessel_a, kind="hold", params={})
    command_enqueue(vessel=vessel_b, kind="hold", params={})
    command_claim_open(vessel=vessel_a)
    command_ack(vessel=vessel_a, uid=old.uid, status="done", detail="armed")
    body = operator.get(commands_url()).json()
    results = body["results"] if isinstance(body, dict) else body
    assert [c["uid"] for c in results] == [str(new.uid), str(old.uid)]
    armed = results[1]
    assert (armed["vessel"], armed["kind"], armed["status"]) == ("spab", "arm", "done")
    assert armed["result_detail"] == "armed"
    assert [(e["from_status"], e["to_status"]) for e in armed["events"]] == [
        ("", "queued"),
        ("queued", "sent"),
        ("sent", "done"),
    ]


def test_it_creates_a_command_through_the_catalog(
    operator: APIClient, vessel_a: Vessel, operator_user: User
) -> None:
    response = operator.post(
        commands_url(), {"kind": "move_to", "params": {"lat": -32, "lon": 115.7}}, format="json"
    )
    assert response.status_code == 201
    body = response.json()
    command = Command.objects.get(uid=body["uid"])
    assert (command.vessel, command.kind, command.status) == (vessel_a, "move_to", "queued")
    assert command.params == {"lat": -32.0, "lon": 115.7}
    assert (command.source, command.created_by) == ("api", "alice")
    assert body["params"] == {"lat": -32.0, "lon": 115.7}
    assert body["events"][0]["to_status"] == "queued"


def test_a_created_command_may_carry_its_own_expiry(operator: APIClient, vessel_a: Vessel) -> None:
    expires = dt.datetime.now(dt.UTC).replace(microsecond=0) + dt.timedelta(hours=1)
    response = operator.post(
        commands_url(), {"kind": "hold", "expires_at": iso(expires)}, format="json"
    )
    assert response.status_code == 201
    assert Command.objects.get().expires_at == expires


@pytest.mark.parametrize(
    ("slug", "body", "field", "message"),
    [
        ("spab", {"kind": "warp", "params": {}}, "kind", "unknown command kind 'warp'"),
        ("spab", {"kind": "fhead", "params": {"bearing": 1}}, "kind", "not available for mavlink"),
        ("glider", {"kind": "move_to", "params": {"lat": 0, "lon": 0}}, "kind", "not available"),
        ("spab", {"kind": "move_to", "params": {"lat": 91, "lon": 0}}, "params", "lat must be"),
        ("spab", {"kind": "move_to", "params": {"lat": True, "lon": 0}}, "params", "lat must be"),
        ("spab", {"kind": "move_to", "params": {"lat": 1}}, "params", "lon is required"),
        ("spab", {"kind": "arm", "params": {"force": 1}}, "params", "unknown parameter 'force'"),
        ("spab", {"kind": "move_to", "params": [1, 2]}, "params", "params must be an object"),
        ("glider", {"kind": "fhead", "params": {"bearing": 360}}, "params", "bearing must be"),
        ("spab", {"params": {}}, "kind", "This field is required."),
        ("spab", {"kind": "hold", "expires_at": "soon"}, "expires_at", "Datetime has wrong"),
        (
            "spab",
            {"kind": "hold", "expires_at": "2020-01-01T00:00:00Z"},
            "non_field_errors",
            "expires_at must be in the future",
        ),
    ],
)
def test_an_invalid_command_is_a_400_naming_the_field(
    operator: APIClient,
    vessel_a: Vessel,
    glider: Vessel,
    slug: str,
    body: dict[str, Any],
    field: str,
    message: str,
) -> None:
    response = operator.post(commands_url(slug), body, format="json")
    assert response.status_code == 400
    answer = response.json()
    assert answer["error"] == "invalid"
    assert list(answer["detail"]) == [field]
    assert message in answer["detail"][field][0]
    assert not Command.objects.exists()


def test_creating_for_an_unknown_vessel_is_a_404(operator: APIClient, vessel_a: Vessel) -> None:
    response = operator.post(commands_url("nope"), {"kind": "hold"}, format="json")
    assert response.status_code == 404
    assert not Command.objects.exists()


def test_malformed_json_is_a_400(operator: APIClient, vessel_a: Vessel) -> None:
    response = operator.post(commands_url(), '{"kind":', content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"


def test_a_deeply_nested_body_is_a_400(operator: APIClient, vessel_a: Vessel) -> None:
    body = '{"kind": "hold", "params": ' + "[" * 100_000 + "]" * 100_000 + "}"
    response = operator.post(commands_url(), body, content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"
    assert not Command.objects.exists()


def test_it_cancels_a_command(operator: APIClient, command_a: Command) -> None:
    response = operator.post(cancel_url(command_a.uid))
    assert response.status_code == 200
    assert response.json()["status"] == "cancelled"
    command_a.refresh_from_db()
    assert command_a.status == Status.CANCELLED
    assert command_a.events.last().actor == "alice"


def test_cancelling_a_finished_command_is_a_409(
    operator: APIClient, vessel_a: Vessel, command_a: Command
) -> None:
    command_claim_open(vessel=vessel_a)
    command_ack(vessel=vessel_a, uid=command_a.uid, status="done")
    response = operator.post(cancel_url(command_a.uid))
    assert response.status_code == 409
    assert response.json() == {
        "error": "conflict",
        "detail": "command is done; it can no longer be cancelled",
    }
    command_a.refresh_from_db()
    assert command_a.status == Status.DONE


@pytest.mark.parametrize("uid", ["nope", "00000000-0000-4000-8000-000000000000"])
def test_cancelling_an_unknown_command_is_a_404(
    operator: APIClient, vessel_a: Vessel, uid: str
) -> None:
    response = operator.post(cancel_url(uid))
    assert response.status_code == 404
    assert response.json() == {"error": "not_found", "detail": "No such command."}


def test_cancel_needs_the_change_permission_not_just_add(
    operator_user: User, command_a: Command
) -> None:
    operator_user.user_permissions.remove(
        *operator_user.user_permissions.filter(codename="change_command")
    )
    client = APIClient()
    client.force_authenticate(User.objects.get(pk=operator_user.pk))
    assert client.post(cancel_url(command_a.uid)).status_code == 403
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


# --- OpenAPI schema and docs page ---


def test_the_openapi_schema_documents_both_apis(session_operator: APIClient) -> None:
    response = session_operator.get("/api/v1/schema/", HTTP_ACCEPT="application/json")
    assert response.status_code == 200
    schema = response.json()
    assert schema["openapi"].startswith("3.")
    for path in (
        "/api/v1/boat/telemetry/",
        "/api/v1/boat/commands/",
        "/api/v1/boat/commands/{uid}/ack/",
        "/api/v1/vessels/",
        "/api/v1/vessels/{slug}/fixes/",
        "/api/v1/vessels/{slug}/commands/",
        "/api/v1/commands/{uid}/cancel/",
    ):
        assert path in schema["paths"], path
    assert not any(p.startswith("/spab/") for p in schema["paths"])
    # Boats and operators authenticate differently, and the schema says so.
    assert schema["components"]["securitySchemes"]["vesselKey"]["name"] == "Authorization"
    assert schema["paths"]["/api/v1/boat/commands/"]["get"]["security"] == [{"vesselKey": []}]
    assert {"vesselKey": []} not in schema["paths"]["/api/v1/vessels/"]["get"]["security"]


def test_the_docs_page_uses_only_local_assets(session_operator: APIClient) -> None:
    response = session_operator.get("/api/v1/docs/")
    assert response.status_code == 200
    html = response.content.decode()
    assets = re.findall(r'(?:src|href)="([^"]+)"', html)
    assert any("swagger-ui" in a for a in assets)
    assert all(a.startswith("/static/") for a in assets), assets
    assert "cdn" not in html.lower()
    assert not re.search(r"https?://(?!localhost|127\.0\.0\.1|testserver)", html)


@pytest.mark.parametrize("path", ["/api/v1/schema/", "/api/v1/docs/"])
def test_schema_and_docs_need_a_login(anonymous: APIClient, boat_a: APIClient, path: str) -> None:
    assert anonymous.get(path).status_code in (401, 403)
    assert boat_a.get(path).status_code in (401, 403)


@pytest.mark.parametrize(
    "path",
    [
        "/api/v1/vessels/nope/fixes/",
        "/api/v1/vessels/nope/commands/",
        "/api/v1/vessels/spab/fixes/?from=x",
    ],
)
def test_an_operator_without_rights_cannot_probe_which_vessels_exist(
    readonly: APIClient, vessel_a: Vessel, path: str
) -> None:
    assert readonly.get(path).status_code == 403
