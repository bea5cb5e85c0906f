"""The audit log's admin: a read-only list with filters, search and dates; nobody edits it."""

from __future__ import annotations

import datetime as dt

import pytest
from django.contrib.auth.models import User
from django.test import Client

from audit import admin as audit_admin
from audit.context import Origin, audit_origin
from audit.models import ActorKind, AuditEntry
from audit.services import audit_record
from tests.conftest import make_user
from tests.support import BASE

LIST = "/admin/audit/auditentry/"


@pytest.fixture
def log(db: None) -> list[AuditEntry]:
    with audit_origin(Origin(actor="alice", via="admin", ip="198.51.100.10")):
        return [
            audit_record(action="key.issued", subject="ssk_abc… (pi) of SPAB", vessel="spab",
                         detail={"prefix": "ssk_abc", "label": "pi"}, now=BASE),
            audit_record(action="command.queued", actor="+61412345678",
                         actor_kind=ActorKind.PHONE, via="sms", subject="fhead → Wave Glider",
                         vessel="glider", now=BASE + dt.timedelta(hours=1)),
            audit_record(action="login.failed", actor="mallory", subject="mallory",
                         ip="203.0.113.66", now=BASE + dt.timedelta(days=1)),
        ]  # fmt: skip


def test_the_list_shows_who_did_what_from_where(admin_client: Client, log: list) -> None:
    page = admin_client.get(LIST).content.decode()
    shown = ["key.issued", "alice", "198.51.100.10", "ssk_abc… (pi) of SPAB",
             "+61412345678 (Phone number)", "login.failed", "mallory", "203.0.113.66"]  # fmt: skip
    for text in shown:
        assert text in page, text


@pytest.mark.parametrize(
    ("query", "shown", "hidden"),
    [
        ("?action=key.issued", "ssk_abc", "mallory"),
        ("?vessel=glider", "fhead", "ssk_abc"),
        ("?actor_kind__exact=phone", "fhead", "mallory"),
        ("?via=sms", "fhead", "ssk_abc"),
        ("?q=mallory", "login.failed", "ssk_abc"),
        ("?q=203.0.113", "mallory", "ssk_abc"),
        ("?at__day=24&at__month=11&at__year=2026", "mallory", "fhead"),
    ],
)
def test_it_filters_searches_and_goes_by_date(
    admin_client: Client, log: list, query: str, shown: str, hidden: str
) -> None:
    response = admin_client.get(LIST + query)
    assert response.status_code == 200
    page = response.content.decode()
    assert shown in page and hidden not in page


def test_the_filters_offer_the_values_the_log_holds(admin_client: Client, log: list) -> None:
    page = admin_client.get(LIST).content.decode()
    for value in ("?action=command.queued", "?vessel=spab", "?vessel=glider", "?via=admin"):
        assert value in page


def test_an_entry_page_is_read_only_and_shows_its_detail(admin_client: Client, log: list) -> None:
    page = admin_client.get(f"{LIST}{log[0].pk}/change/").content.decode()
    assert "&quot;label&quot;: &quot;pi&quot;" in page
    assert 'name="_save"' not in page and "deletelink" not in page


def test_nobody_adds_changes_or_deletes_an_entry(admin_client: Client, log: list) -> None:
    entry = log[0]
    assert admin_client.get(f"{LIST}add/").status_code == 403
    assert admin_client.post(f"{LIST}{entry.pk}/change/", {"action": "x"}).status_code == 403
    assert admin_client.post(f"{LIST}{entry.pk}/delete/", {"post": "yes"}).status_code == 403
    admin_client.post(LIST, {"action": "delete_selected", "_selected_action": [entry.pk]})
    assert AuditEntry.objects.filter(pk=entry.pk, action="key.issued").exists()


def test_an_operator_needs_the_view_permission(log: list) -> None:
    bob, carol = make_user("bob", []), make_user("carol", ["audit.view_auditentry"])
    assert logged_in(bob).get(LIST).status_code == 403
    assert logged_in(carol).get(LIST).status_code == 200


def logged_in(user: User) -> Client:
    client = Client()
    client.force_login(user)
    return client


def test_the_count_is_capped_not_a_full_scan(
    admin_client: Client, log: list, monkeypatch: pytest.MonkeyPatch
) -> None:
    every = AuditEntry.objects.count()  # the log, and the admin's own login
    assert every > 2 and f"{every} audit log" in admin_client.get(LIST).content.decode()
    monkeypatch.setattr(audit_admin, "COUNT_CAP", 2)
    assert "2 audit log" in admin_client.get(LIST).content.decode()
