"""The boat-view base (vessels.api.boat): key authentication on every v1 boat endpoint, JSON
only, no browser headers."""

from __future__ import annotations

import base64

import pytest
from rest_framework.test import APIClient

from commands.lifecycle import Status
from commands.models import Command
from tests.support import BROWSER_HEADERS, COMMANDS, ENDPOINTS, TELEMETRY, MakeFix, ack_url, call
from vessels.models import Vessel


@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_anonymous_gets_401_on_every_boat_endpoint(
    anonymous: APIClient, command_a: Command, endpoint: str
) -> None:
    response = call(anonymous, endpoint, command_a.uid)
    assert response.status_code == 401
    assert response["WWW-Authenticate"] == "Api-Key"
    assert response.json() == {
        "error": "not_authenticated",
        "detail": "Authentication credentials were not provided.",
    }


@pytest.mark.parametrize("persona", ["session_operator", "token_operator", "operator"])
@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_operators_are_not_boats(
    request: pytest.FixtureRequest, command_a: Command, persona: str, endpoint: str
) -> None:
    client: APIClient = request.getfixturevalue(persona)
    response = call(client, endpoint, command_a.uid)
    # A real session or token is not even tried on the boat API (401); a user forced onto
    # the request (DRF's test shortcut) is known but is not a boat (403).
    assert response.status_code == (403 if persona == "operator" else 401)
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_a_revoked_key_gets_401(revoked_boat: APIClient, command_a: Command, endpoint: str) -> None:
    response = call(revoked_boat, endpoint, command_a.uid)
    assert response.status_code == 401
    assert response.json() == {
        "error": "authentication_failed",
        "detail": "This vessel key has been revoked.",
    }


@pytest.mark.parametrize(
    "header",
    [
        "Api-Key",
        "Api-Key ",
        "Api-Key not-a-key",
        "Api-Key " + "x" * 500,
        "api-key ssk_wrong",
        "Bearer abc",
        "Basic " + base64.b64encode(b"spab:whatever").decode(),
    ],
)
@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_a_malformed_or_wrong_header_gets_401(
    command_a: Command, header: str, endpoint: str
) -> None:
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=header)
    response = call(client, endpoint, command_a.uid)
    assert response.status_code == 401
    assert response.json()["error"] in {"authentication_failed", "not_authenticated"}


def test_a_key_of_an_inactive_vessel_gets_401(vessel_a: Vessel, boat_a: APIClient) -> None:
    Vessel.objects.filter(pk=vessel_a.pk).update(active=False)
    response = boat_a.get(COMMANDS)
    assert response.status_code == 401
    assert response.json()["detail"] == "This vessel is not active."


def test_the_scheme_name_is_case_insensitive(key_a: str) -> None:
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=f"api-key {key_a}")
    assert client.get(COMMANDS).status_code == 200


@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_boat_a_is_served(boat_a: APIClient, command_a: Command, endpoint: str) -> None:
    if endpoint == "ack":
        boat_a.get(COMMANDS)
    assert call(boat_a, endpoint, command_a.uid).status_code == 200


def test_boat_responses_carry_no_browser_headers(boat_a: APIClient, make_fix: MakeFix) -> None:
    for response in (
        boat_a.get(COMMANDS),
        boat_a.post(TELEMETRY, [make_fix()], format="json"),
        boat_a.post(TELEMETRY, "{", content_type="application/json"),
    ):
        for header in BROWSER_HEADERS:
            assert header not in response.headers, header


def test_operator_pages_keep_their_browser_headers(operator: APIClient) -> None:
    response = operator.get("/api/v1/vessels/")
    assert response["X-Frame-Options"] == "DENY"
    assert response["X-Content-Type-Options"] == "nosniff"


# ~200 kB of brackets: Python's json raises RecursionError, which is no ValueError (a 500).
DEEPLY_NESTED = "[" * 100_000 + "]" * 100_000


@pytest.mark.parametrize("path", [TELEMETRY, ack_url("00000000-0000-4000-8000-000000000000")])
def test_a_deeply_nested_body_is_a_400(boat_a: APIClient, path: str) -> None:
    response = boat_a.post(path, DEEPLY_NESTED, content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"
    assert "nested" in response.json()["detail"]


def test_a_key_use_updates_last_seen_even_without_fixes(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    assert boat_a.get(COMMANDS).status_code == 200
    vessel_a.refresh_from_db()
    assert vessel_a.last_seen_at is not None


@pytest.mark.parametrize(
    ("path", "allowed"),
    [
        ("/api/v1/boat/commands/", {"GET", "HEAD", "OPTIONS"}),
        ("/api/v1/boat/telemetry/", {"POST", "OPTIONS"}),
        ("/spab/requestCommands.cgi", {"GET", "HEAD", "OPTIONS"}),
    ],
)
def test_a_405_on_a_boat_path_says_which_methods_are_allowed(
    boat_a: APIClient, path: str, allowed: set[str]
) -> None:
    response = boat_a.put(path, {}, format="json")
    assert response.status_code == 405
    assert {m.strip() for m in response["Allow"].split(",")} == allowed
