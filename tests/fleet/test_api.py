"""The operator API as assembled: who may call what, the OpenAPI schema and the docs page."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from typing import Any

import pytest
from django.contrib.auth.models import User
from django.test import Client
from rest_framework.test import APIClient

from commands.lifecycle import Status
from commands.models import Command
from tests.conftest import make_user
from tests.support import VESSELS, cancel_url, commands_url, fixes_url
from vessels.api import views as vessel_views
from vessels.models import Vessel

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
    # A CDN host ("cdn.", "//cdn"), not the letters: the page's random CSRF token may hold them.
    assert not re.search(r"cdn\.|//cdn", html, re.IGNORECASE)
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


@pytest.mark.parametrize(
    ("perms", "path"),
    [
        (["commands.view_command"], "/api/v1/vessels/{}/commands/"),
        (["commands.view_command", "commands.add_command"], "/api/v1/vessels/{}/commands/"),
        (["telemetry.view_fix"], "/api/v1/vessels/{}/fixes/"),
    ],
)
def test_partial_rights_do_not_tell_which_vessel_slugs_exist(
    vessel_a: Vessel, perms: list[str], path: str
) -> None:
    client = APIClient()
    client.force_authenticate(make_user("carol", perms))
    answers = {
        (client.get(path.format(slug)).status_code, client.post(path.format(slug)).status_code)
        for slug in ("spab", "nope")
    }
    assert len(answers) == 1  # the same for a vessel that exists and one that does not
    assert answers.pop()[0] == 403


@pytest.fixture
def no_raise(operator_user: User) -> Client:
    """Alice through a client that returns Django's 500 page instead of raising."""
    client = Client(raise_request_exception=False)
    client.force_login(operator_user)
    return client


@pytest.mark.parametrize("path", ["/api/v1/nope/", "/api/v1/vessels/spab/nope/", "/api/nope"])
def test_an_unmatched_api_url_is_a_json_404(no_raise: Client, vessel_a: Vessel, path: str) -> None:
    response = no_raise.get(path)
    assert response.status_code == 404
    assert response.json() == {"error": "not_found", "detail": "No such endpoint."}


def test_an_unhandled_error_under_the_api_is_a_json_500(
    no_raise: Client, vessel_a: Vessel, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken() -> Any:
        raise RuntimeError("a bug")

    monkeypatch.setattr(vessel_views, "vessel_list", broken)
    response = no_raise.get(VESSELS)
    assert response.status_code == 500
    assert response.json()["error"] == "server_error"


@pytest.mark.parametrize(
    ("path", "shape"),
    [
        ("/api/v1/boat/telemetry/", "api"),
        ("/api/v1/vessels/spab/commands/", "api"),
        ("/spab/data.cgi", "legacy"),
    ],
)
def test_a_body_over_the_size_limit_is_a_json_413(
    no_raise: Client, key_a: str, settings: Any, path: str, shape: str
) -> None:
    settings.DATA_UPLOAD_MAX_MEMORY_SIZE = 1000
    body = json.dumps([{"lat": 1, "lon": 2, "pad": "x" * 2000}])
    headers = {"HTTP_AUTHORIZATION": f"Api-Key {key_a}"} if "commands" not in path else {}
    response = no_raise.post(path, body, content_type="application/json", **headers)
    assert response.status_code == 413
    answer = response.json()
    detail = answer["detail"] if shape == "api" else answer[1]["message"]
    assert "over 1000 bytes" in detail


@pytest.mark.parametrize(
    "path",
    ["/api/v1/vessels/%00/", "/api/v1/vessels/%00/fixes/", "/api/v1/commands/%00/cancel/"],
)
def test_a_nul_in_an_api_path_is_a_404(no_raise: Client, vessel_a: Vessel, path: str) -> None:
    response = no_raise.get(path)
    assert response.status_code == 404
    assert response.json()["error"] == "not_found"


@pytest.mark.parametrize(
    "query",
    [
        "/admin/commands/command/?status__exact=%00",
        "/admin/vessels/vessel/?q=%00",
        "/admin/telemetry/fix/?vessel=%00",
        "/api/v1/vessels/spab/fixes/?from=%00",
    ],
)
def test_a_nul_in_a_filter_value_is_a_404_not_a_500(
    admin_ui: Client, vessel_a: Vessel, query: str
) -> None:
    admin_ui.raise_request_exception = False
    assert admin_ui.get(query).status_code == 404


def test_every_operation_documents_the_errors_it_can_answer(session_operator: APIClient) -> None:
    schema = session_operator.get("/api/v1/schema/", HTTP_ACCEPT="application/json").json()
    error = {"$ref": "#/components/schemas/Error"}
    expected = {
        ("post", "/api/v1/boat/telemetry/"): {"400", "401", "413", "415", "429", "503"},
        ("get", "/api/v1/boat/commands/"): {"304", "401", "503"},
        ("post", "/api/v1/boat/commands/{uid}/ack/"): {"400", "401", "404", "409", "415"},
        ("get", "/api/v1/vessels/{slug}/fixes/"): {"400", "403", "404"},
        ("post", "/api/v1/vessels/{slug}/commands/"): {"400", "403", "404", "415"},
        ("post", "/api/v1/commands/{uid}/cancel/"): {"403", "404", "409"},
    }
    for (method, path), codes in expected.items():
        responses = schema["paths"][path][method]["responses"]
        assert codes <= set(responses), (method, path, sorted(responses))
        for code in codes - {"304"}:
            assert responses[code]["content"]["application/json"]["schema"] == error
    assert set(schema["components"]["schemas"]["Error"]["required"]) == {"error", "detail"}


def test_each_operation_documents_the_auth_failure_it_answers(
    session_operator: APIClient, anonymous: APIClient, boat_a: APIClient, command_a: Command
) -> None:
    """A boat operation answers 401 (its key scheme names a challenge), an operator operation
    403 (the session scheme comes first and names none): each documents only its own."""
    schema = session_operator.get("/api/v1/schema/", HTTP_ACCEPT="application/json").json()
    for path, operations in schema["paths"].items():
        for method, operation in operations.items():
            boat = path.startswith("/api/v1/boat/")
            codes = set(operation["responses"])
            assert ("401" in codes, "403" in codes) == (boat, not boat), (method, path)
    assert anonymous.get("/api/v1/boat/commands/").status_code == 401
    assert boat_a.get("/api/v1/fleet/").status_code == 403
    assert anonymous.get("/api/v1/vessels/").status_code == 403
    bad_token = APIClient()
    bad_token.credentials(HTTP_AUTHORIZATION="Token sst_" + "0" * 64)
    assert bad_token.get("/api/v1/vessels/").status_code == 403
    assert bad_token.get("/api/v1/boat/commands/").status_code == 401


def test_the_schema_endpoint_answers_its_own_errors_in_json(anonymous: APIClient) -> None:
    response = anonymous.get("/api/v1/schema/")
    assert response.status_code == 403
    assert response["Content-Type"] == "application/json"
    assert response.json()["error"] == "not_authenticated"


def test_the_schema_gives_the_map_reads_their_ranges(session_operator: APIClient) -> None:
    paths = session_operator.get("/api/v1/schema/", HTTP_ACCEPT="application/json").json()["paths"]

    def parameter(path: str, name: str) -> dict[str, Any]:
        found = [p for p in paths[path]["get"]["parameters"] if p["name"] == name]
        return found[0]

    track = parameter("/api/v1/vessels/{slug}/track/", "max_points")["schema"]
    assert (track["minimum"], track["maximum"]) == (6, 10000)
    buckets = parameter("/api/v1/vessels/{slug}/series/", "buckets")["schema"]
    assert (buckets["minimum"], buckets["maximum"]) == (1, 5000)
    time = parameter("/api/v1/vessels/{slug}/fixes/nearest/", "time")
    assert time["required"] is True
    assert time["schema"]["minLength"] == 1


def test_the_schema_types_the_telemetry_body_and_the_csv_export(
    session_operator: APIClient,
) -> None:
    schema = session_operator.get("/api/v1/schema/", HTTP_ACCEPT="application/json").json()
    components = schema["components"]["schemas"]
    body = schema["paths"]["/api/v1/boat/telemetry/"]["post"]["requestBody"]
    batch_ref, bare_list = body["content"]["application/json"]["schema"]["anyOf"]
    fixes = components[batch_ref["$ref"].rsplit("/", 1)[1]]["properties"]["fixes"]
    assert bare_list["type"] == "array"
    assert fixes["maxItems"] == bare_list["maxItems"] == 5000
    # Each entry is checked alone (a bad one is listed in `rejected`), so any entry is taken.
    fix_ref, other = fixes["items"]["anyOf"]
    fix = fix_ref["$ref"].rsplit("/", 1)[1]
    assert "type" not in other
    assert {"time", "lat", "lon", "readings"} <= set(components[fix]["properties"])
    assert {"time", "lat", "lon"} <= set(components[fix]["required"])
    fixes = schema["paths"]["/api/v1/vessels/{slug}/fixes/"]["get"]["responses"]["200"]
    assert set(fixes["content"]) == {"application/json", "text/csv"}
