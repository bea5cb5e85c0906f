"""Operators' personal API tokens (operators app): hashed, named, expiring, revocable."""

from __future__ import annotations

import io
from datetime import timedelta

import pytest
import time_machine
from django.contrib.auth.models import User
from django.core.exceptions import ValidationError
from django.core.management import CommandError, call_command
from django.db import connection
from django.test.utils import CaptureQueriesContext
from django.utils import timezone
from knox.crypto import hash_token
from rest_framework.test import APIClient, APIRequestFactory

from operators.auth import OperatorTokenAuthentication
from operators.models import OperatorToken
from operators.services import operator_token_issue, operator_token_revoke


def token_client(raw: str) -> APIClient:
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=f"Token {raw}")
    return client


def refused(response) -> bool:
    """Refused at authentication (403: session authentication, first, names no scheme)."""
    return response.status_code == 403 and response.json()["error"] == "authentication_failed"


def test_only_a_digest_and_a_short_lookup_key_are_stored(operator_user: User) -> None:
    token, raw = operator_token_issue(user=operator_user, name="laptop", expires_in=None)
    token.refresh_from_db()
    assert raw.startswith("sst_") and len(raw) == 4 + 64
    assert token.digest == hash_token(raw)
    assert token.token_key == raw[:15]
    stored = [str(v) for v in OperatorToken.objects.values_list(flat=False).get()]
    assert not any(raw in value for value in stored)


def test_a_token_authenticates_its_owner(operator_user: User, vessel_a) -> None:
    _token, raw = operator_token_issue(user=operator_user, name="script", expires_in=None)
    assert token_client(raw).get("/api/v1/vessels/").status_code == 200


def test_the_lookup_is_one_indexed_query(operator_user: User) -> None:
    _token, raw = operator_token_issue(
        user=operator_user, name="script", expires_in=timedelta(days=1)
    )
    for n in range(3):  # other tokens of the same user cost nothing either
        operator_token_issue(user=operator_user, name=f"other {n}", expires_in=timedelta(days=1))
    request = APIRequestFactory().get("/", HTTP_AUTHORIZATION=f"Token {raw}")
    with CaptureQueriesContext(connection) as queries:
        user, token = OperatorTokenAuthentication().authenticate(request)
        assert user.username == "alice" and token.name == "script"
    assert len(queries) == 1
    assert "token_key" in queries[0]["sql"]


@pytest.mark.parametrize(
    "header",
    ["Token sst_nonsense", "Token ", "Token a b", "Token sst_\xe9t\xe9", "Token " + "f" * 5000],
)
def test_a_wrong_token_is_refused(operator_user: User, vessel_a, header: str) -> None:
    operator_token_issue(user=operator_user, name="script", expires_in=None)
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=header)
    response = client.get("/api/v1/vessels/")
    # 403, not 401: session authentication comes first and names no WWW-Authenticate scheme.
    assert response.status_code == 403
    assert response.json()["error"] == "authentication_failed"


def test_a_revoked_token_is_refused(operator_user: User, vessel_a) -> None:
    token, raw = operator_token_issue(user=operator_user, name="script", expires_in=None)
    client = token_client(raw)
    assert client.get("/api/v1/vessels/").status_code == 200
    operator_token_revoke(token=token)
    assert refused(client.get("/api/v1/vessels/"))
    assert not OperatorToken.objects.exists()


def test_an_expired_token_is_refused_and_stays_listed(operator_user: User, vessel_a) -> None:
    token, raw = operator_token_issue(
        user=operator_user, name="script", expires_in=timedelta(days=1)
    )
    client = token_client(raw)
    with time_machine.travel(timezone.now() + timedelta(hours=23), tick=False):
        assert client.get("/api/v1/vessels/").status_code == 200
    with time_machine.travel(timezone.now() + timedelta(days=1, seconds=1), tick=False):
        assert refused(client.get("/api/v1/vessels/"))
        token.refresh_from_db()
        assert token.is_expired()


def test_an_inactive_operators_token_is_refused(operator_user: User, vessel_a) -> None:
    _token, raw = operator_token_issue(user=operator_user, name="script", expires_in=None)
    operator_user.is_active = False
    operator_user.save()
    assert refused(token_client(raw).get("/api/v1/vessels/"))


def test_tokens_are_not_issued_to_inactive_users_or_already_expired(
    operator_user: User,
) -> None:
    with pytest.raises(ValidationError, match="expire in the future"):
        operator_token_issue(user=operator_user, name="x", expires_in=timedelta(0))
    operator_user.is_active = False
    with pytest.raises(ValidationError, match="not an active user"):
        operator_token_issue(user=operator_user, name="x", expires_in=None)
    assert not OperatorToken.objects.exists()


# --- manage.py issue_token ---


def test_issue_token_prints_the_token_once_and_alone(operator_user: User, vessel_a) -> None:
    out, err = io.StringIO(), io.StringIO()
    call_command(
        "issue_token",
        "alice",
        "--name",
        "ops laptop",
        "--expires-days",
        "7",
        stdout=out,
        stderr=err,
    )
    raw = out.getvalue().strip()
    token = OperatorToken.objects.get()
    assert token.digest == hash_token(raw) and token.name == "ops laptop"
    assert token.expiry - token.created == pytest.approx(
        timedelta(days=7), abs=timedelta(seconds=5)
    )
    assert raw not in err.getvalue()
    assert token_client(raw).get("/api/v1/vessels/").status_code == 200


def test_issue_token_with_zero_days_never_expires(operator_user: User) -> None:
    call_command(
        "issue_token",
        "alice",
        "--name",
        "ci",
        "--expires-days",
        "0",
        stdout=io.StringIO(),
        stderr=io.StringIO(),
    )
    assert OperatorToken.objects.get().expiry is None


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["nobody", "--name", "x"], "No user 'nobody'"),
        (["alice", "--name", "x", "--expires-days", "-1"], "0 \\(never\\) or more"),
        (["alice", "--name", "x" * 101], "at most 100 characters"),
    ],
)
def test_issue_token_refuses_bad_input_clearly(
    operator_user: User, args: list[str], message: str
) -> None:
    out = io.StringIO()
    with pytest.raises(CommandError, match=message):
        call_command("issue_token", *args, stdout=out, stderr=io.StringIO())
    assert out.getvalue() == ""
    assert not OperatorToken.objects.exists()


def test_the_openapi_schema_describes_the_operator_token(session_operator: APIClient) -> None:
    schema = session_operator.get("/api/v1/schema/", HTTP_ACCEPT="application/json").json()
    scheme = schema["components"]["securitySchemes"]["operatorToken"]
    assert (scheme["type"], scheme["name"]) == ("apiKey", "Authorization")
    assert {"operatorToken": []} in schema["paths"]["/api/v1/vessels/"]["get"]["security"]


@pytest.mark.django_db
def test_knox_leaves_no_table_of_its_own() -> None:
    # Its model is swapped for OperatorToken; an unused knox_authtoken table would still hold
    # a foreign key to auth_user, and PostgreSQL refuses flush's TRUNCATE because of it.
    tables = connection.introspection.table_names()
    assert "operators_operatortoken" in tables
    assert not [t for t in tables if t.startswith("knox_")]


@pytest.mark.django_db(transaction=True)
def test_the_old_plaintext_token_table_is_dropped_on_upgrade() -> None:
    call_command("migrate", "operators", "0001", verbosity=0)
    with connection.cursor() as cursor:  # what an install from before knox still holds
        cursor.execute("CREATE TABLE authtoken_token (key varchar(40) PRIMARY KEY)")
        cursor.execute("INSERT INTO authtoken_token VALUES ('0123456789abcdef')")
    call_command("migrate", "operators", verbosity=0)
    assert "authtoken_token" not in connection.introspection.table_names()
