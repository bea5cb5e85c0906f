"""The legacy boat-view base: the three old ways to send a key, and telemAck-shaped refusals."""

from __future__ import annotations

import base64
import json

import pytest
from rest_framework.test import APIClient

from telemetry.models import Fix
from tests.support import BROWSER_HEADERS, DATA, LEGACY_COMMANDS, LISTING_1, post_data, telem_ack
from vessels.models import Vessel


def basic(slug: str, key: str) -> str:
    return "Basic " + base64.b64encode(f"{slug}:{key}".encode()).decode()


@pytest.mark.parametrize("how", ["authorization", "api-key-header", "basic", "query"])
def test_it_takes_the_key_in_each_of_the_old_ways(key_a: str, vessel_a: Vessel, how: str) -> None:
    client = APIClient()
    url = DATA
    if how == "authorization":
        client.credentials(HTTP_AUTHORIZATION=f"Api-Key {key_a}")
    elif how == "api-key-header":
        client.credentials(HTTP_API_KEY=key_a)
    elif how == "basic":
        client.credentials(HTTP_AUTHORIZATION=basic("spab", key_a))
    else:
        url = f"{DATA}?key={key_a}"
    response = client.post(url, json.dumps(LISTING_1), content_type="application/json")
    assert response.status_code == 200
    assert vessel_a.fixes.count() == 2
    commands = client.get(LEGACY_COMMANDS if how != "query" else f"{LEGACY_COMMANDS}?key={key_a}")
    assert commands.status_code == 200


@pytest.mark.parametrize(
    ("credentials", "query", "message"),
    [
        ({}, "", "Authentication credentials were not provided."),
        ({"HTTP_AUTHORIZATION": "BASIC_SPAB"}, "", "Authentication credentials were not provided."),
        ({"HTTP_API_KEY": "ssk_nope"}, "", "Invalid vessel key."),
        ({}, "?key=ssk_nope", "Invalid vessel key."),
        ({"HTTP_AUTHORIZATION": "Basic !!!"}, "", "Malformed Basic credentials."),
        # Header values arrive as latin-1 text: base64 of non-ASCII raised ValueError (a 500).
        ({"HTTP_AUTHORIZATION": "Basic é"}, "", "Malformed Basic credentials."),
    ],
)
@pytest.mark.parametrize("path", [DATA, LEGACY_COMMANDS])
def test_missing_or_wrong_keys_get_a_401_telem_ack(
    vessel_a: Vessel, credentials: dict[str, str], query: str, message: str, path: str
) -> None:
    client = APIClient()
    client.credentials(**credentials)
    response = (
        client.get(path + query)
        if path == LEGACY_COMMANDS
        else client.post(path + query, json.dumps(LISTING_1), content_type="application/json")
    )
    assert response.status_code == 401
    assert response["WWW-Authenticate"] == 'Basic realm="shoreside"'
    assert telem_ack(response) == ("false", message)
    assert not Fix.objects.exists()


def test_basic_auth_with_another_vessels_slug_gets_401(key_a: str, vessel_b: Vessel) -> None:
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=basic("spab-2", key_a))
    response = post_data(client, LISTING_1)
    assert response.status_code == 401
    assert telem_ack(response) == ("false", "The key does not belong to that vessel.")
    assert not Fix.objects.exists()


@pytest.mark.parametrize("how", ["authorization", "basic", "query"])
def test_a_revoked_key_gets_401_whichever_way_it_comes(revoked_key_a: str, how: str) -> None:
    client = APIClient()
    url = DATA
    if how == "authorization":
        client.credentials(HTTP_AUTHORIZATION=f"Api-Key {revoked_key_a}")
    elif how == "basic":
        client.credentials(HTTP_AUTHORIZATION=basic("spab", revoked_key_a))
    else:
        url += f"?key={revoked_key_a}"
    response = client.post(url, json.dumps(LISTING_1), content_type="application/json")
    assert response.status_code == 401
    assert telem_ack(response) == ("false", "This vessel key has been revoked.")


def test_an_operator_is_not_a_legacy_boat(operator: APIClient) -> None:
    response = post_data(operator, LISTING_1)
    assert response.status_code == 403
    assert telem_ack(response)[0] == "false"
    assert not Fix.objects.exists()


def test_legacy_responses_carry_no_browser_headers(boat_a: APIClient) -> None:
    for response in (
        post_data(boat_a, LISTING_1),
        boat_a.get(LEGACY_COMMANDS),
        post_data(APIClient(), []),
    ):
        for header in BROWSER_HEADERS:
            assert header not in response.headers


# --- requestCommands.cgi (docs/api.md#legacy-spab-endpoints) ---
