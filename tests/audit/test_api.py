"""GET /api/v1/audit/: who may read the log, its filters and its pages."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from rest_framework.test import APIClient

from audit.models import ActorKind, AuditEntry
from audit.services import audit_record
from tests.conftest import make_user
from tests.support import BASE, iso
from vessels.models import Vessel
from vessels.services import vessel_key_issue

AUDIT = "/api/v1/audit/"


@pytest.fixture
def auditor(db: None) -> APIClient:
    """Dana: may read the audit log and nothing else."""
    client = APIClient()
    client.force_authenticate(make_user("dana", ["audit.view_auditentry"]))
    return client


@pytest.fixture
def log(db: None) -> list[AuditEntry]:
    at = [BASE + dt.timedelta(minutes=m) for m in range(4)]
    return [
        audit_record(action="key.issued", actor="alice", via="admin", vessel="spab", now=at[0]),
        audit_record(action="command.queued", actor="alice", via="api", vessel="spab",
                     ip="198.51.100.10", now=at[1]),
        audit_record(action="command.queued", actor="+61412345678", actor_kind=ActorKind.PHONE,
                     via="sms", vessel="glider", now=at[2]),
        audit_record(action="command.cancelled", actor="bob", via="api", vessel="spab",
                     subject_type="command", subject_id="u-1", now=at[3]),
    ]  # fmt: skip


def actions(response: Any) -> list[tuple[str, str]]:
    assert response.status_code == 200, response.json()
    return [(e["action"], e["actor"]) for e in response.json()["results"]]


def test_it_lists_the_log_newest_first(auditor: APIClient, log: list) -> None:
    response = auditor.get(AUDIT)
    assert actions(response) == [
        ("command.cancelled", "bob"),
        ("command.queued", "+61412345678"),
        ("command.queued", "alice"),
        ("key.issued", "alice"),
    ]
    second = response.json()["results"][2]
    assert second == {
        "id": log[1].pk, "at": iso(BASE + dt.timedelta(minutes=1)), "actor": "alice",
        "actor_kind": "operator", "via": "api", "ip": "198.51.100.10",
        "action": "command.queued", "subject_type": "", "subject_id": "", "subject": "",
        "vessel": "spab", "detail": {},
    }  # fmt: skip


@pytest.mark.parametrize(
    ("query", "expected"),
    [
        ("vessel=glider", [("command.queued", "+61412345678")]),
        ("action=command.queued", [("command.queued", "+61412345678"),
                                   ("command.queued", "alice")]),
        ("action=command", [("command.cancelled", "bob"), ("command.queued", "+61412345678"),
                            ("command.queued", "alice")]),
        ("action=comm", []),  # a kind is a whole word before the dot
        ("actor=alice", [("command.queued", "alice"), ("key.issued", "alice")]),
        ("actor_kind=phone", [("command.queued", "+61412345678")]),
        ("via=api&vessel=spab", [("command.cancelled", "bob"), ("command.queued", "alice")]),
        ("subject_type=command&subject_id=u-1", [("command.cancelled", "bob")]),
        ("since=2026-11-23T08:02:00Z", [("command.cancelled", "bob"),
                                        ("command.queued", "+61412345678")]),
        ("until=2026-11-23T08:01:00%2B00:00", [("key.issued", "alice")]),
        ("since=2026-11-23T08:01:00&until=2026-11-23T08:02:00", [("command.queued", "alice")]),
        # An offset PostgreSQL would refuse (past ±15:59) is taken as the same instant in UTC.
        ("since=2026-11-24T07:02:00%2B23:00", [("command.cancelled", "bob"),
                                               ("command.queued", "+61412345678")]),
        ("vessel=nowhere", []),
    ],
)  # fmt: skip
def test_it_filters(auditor: APIClient, log: list, query: str, expected: list) -> None:
    assert actions(auditor.get(f"{AUDIT}?{query}")) == expected


@pytest.mark.parametrize(
    ("query", "field"),
    [
        ("since=yesterday", "since"),
        ("since=", "since"),
        ("actor_kind=", "actor_kind"),
        ("until=2026-13-01T00:00:00Z", "until"),
        ("until=0001-01-01T00:00:00%2B23:00", "until"),  # before year 1 in UTC
        ("actor_kind=robot", "actor_kind"),
        ("cursor=not-a-cursor", "cursor"),
        ("page_size=null", "page_size"),
        ("page_size=0", "page_size"),
        ("page_size=1001", "page_size"),
    ],
)
def test_bad_input_is_a_400_naming_the_field(
    auditor: APIClient, log: list, query: str, field: str
) -> None:
    response = auditor.get(f"{AUDIT}?{query}")
    assert response.status_code == 400
    assert response.json()["error"] == "invalid" or field in str(response.json()["detail"])
    assert field in response.json()["detail"]


def test_it_pages_with_a_cursor(auditor: APIClient, log: list) -> None:
    first = auditor.get(f"{AUDIT}?page_size=3").json()
    assert len(first["results"]) == 3 and first["previous"] is None
    second = auditor.get(first["next"]).json()
    assert [e["action"] for e in second["results"]] == ["key.issued"]
    assert second["next"] is None


def test_entries_outlive_their_vessel(auditor: APIClient, vessel_a: Vessel) -> None:
    vessel_key_issue(vessel=vessel_a, label="pi", created_by="alice")
    vessel_a.delete()
    assert actions(auditor.get(f"{AUDIT}?vessel=spab")) == [("key.issued", "alice")]


def test_a_stranger_and_the_anonymous_are_refused(
    anonymous: APIClient, readonly: APIClient, log: list
) -> None:
    assert anonymous.get(AUDIT).status_code == 403
    assert anonymous.get(AUDIT).json()["error"] == "not_authenticated"
    refused = readonly.get(AUDIT)  # logged in, without audit.view_auditentry
    assert refused.status_code == 403 and refused.json()["error"] == "permission_denied"


def test_an_operator_with_other_rights_only_is_refused(operator: APIClient, log: list) -> None:
    assert operator.get(AUDIT).status_code == 403


def test_a_boat_is_refused(boat_a: APIClient, log: list) -> None:
    assert boat_a.get(AUDIT).status_code == 403


def test_the_log_cannot_be_written_through_the_api(auditor: APIClient, log: list) -> None:
    response = auditor.post(AUDIT, {"action": "key.issued"}, format="json")
    assert response.status_code in (403, 405)
    assert AuditEntry.objects.count() == 4


def test_it_reads_through_a_token_too(log: list) -> None:
    from operators.services import operator_token_issue

    user = make_user("erin", ["audit.view_auditentry"])
    _token, raw = operator_token_issue(user=user, name="script", expires_in=None)
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=f"Token {raw}")
    assert len(actions(client.get(AUDIT))) == 4 + 1  # its own token.issued


def test_it_is_in_the_openapi_schema(auditor: APIClient) -> None:
    from drf_spectacular.generators import SchemaGenerator

    schema = SchemaGenerator().get_schema(request=None, public=True)
    operation = schema["paths"]["/api/v1/audit/"]["get"]
    names = {p["name"] for p in operation["parameters"]}
    assert {"vessel", "action", "actor", "since", "until", "cursor"} <= names
    assert {"200", "400", "403"} <= set(operation["responses"])
