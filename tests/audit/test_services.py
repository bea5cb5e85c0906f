"""audit_record: one entry in the caller's transaction, its blanks from the origin in force,
and never failing the action it records."""

from __future__ import annotations

import pytest
from django.db import transaction

from audit.context import Origin, audit_origin
from audit.models import ActorKind, AuditEntry
from audit.services import audit_record
from vessels.models import Vessel
from vessels.services import vessel_key_issue

OFFICE = Origin(actor="alice", via="admin", ip="198.51.100.10")


@pytest.mark.django_db
def test_an_entry_takes_what_it_is_told() -> None:
    entry = audit_record(
        action="command.queued", actor="+61412345678", actor_kind=ActorKind.PHONE, via="sms",
        subject_type="command", subject_id=7, subject="hold → SPAB", vessel="spab",
        detail={"kind": "hold"},
    )  # fmt: skip
    entry.refresh_from_db()
    assert (entry.actor, entry.actor_kind, entry.via, entry.ip) == (
        "+61412345678", "phone", "sms", None,
    )  # fmt: skip
    assert (entry.subject_type, entry.subject_id, entry.vessel) == ("command", "7", "spab")
    assert entry.detail == {"kind": "hold"}


@pytest.mark.django_db
def test_the_blanks_come_from_the_origin_in_force() -> None:
    with audit_origin(OFFICE):
        entry = audit_record(action="key.revoked")
    assert (entry.actor, entry.actor_kind, entry.via, entry.ip) == (
        "alice", "operator", "admin", "198.51.100.10",
    )  # fmt: skip


@pytest.mark.django_db
def test_what_the_service_says_wins_over_the_origin() -> None:
    with audit_origin(OFFICE):
        entry = audit_record(action="command.queued", actor="bob", via="map")
    assert (entry.actor, entry.via) == ("bob", "map")


@pytest.mark.django_db
def test_a_phone_is_not_given_the_relaying_requests_address() -> None:
    """An SMS posted by a glider comes from the glider's address, not the phone's."""
    with audit_origin(OFFICE):
        entry = audit_record(action="command.queued", actor="+614", actor_kind=ActorKind.PHONE)
    assert entry.ip is None


@pytest.mark.django_db
def test_the_origins_own_actor_named_again_keeps_its_kind() -> None:
    shell = Origin(actor="root (manage.py)", actor_kind=ActorKind.SYSTEM, via="cli")
    with audit_origin(shell):
        entry = audit_record(action="key.issued", actor="root (manage.py)")
    assert (entry.actor_kind, entry.via) == ("system", "cli")


@pytest.mark.django_db
def test_an_origin_is_worked_out_once_and_only_when_an_entry_is_written() -> None:
    calls = []

    def lazy() -> Origin:
        calls.append(1)
        return OFFICE

    with audit_origin(lazy):
        assert calls == []
        audit_record(action="a.one")
        audit_record(action="a.two")
    assert calls == [1]
    assert list(AuditEntry.objects.values_list("actor", flat=True)) == ["alice", "alice"]


@pytest.mark.django_db
def test_outside_any_origin_an_entry_says_only_what_it_was_told() -> None:
    with audit_origin(OFFICE):
        pass
    entry = audit_record(action="alert.acknowledged")
    assert (entry.actor, entry.via, entry.ip) == ("", "", None)


@pytest.mark.django_db
@pytest.mark.parametrize("odd", ["unknown", "198.51.100.10:4431", "", "::ffff:zz"])
def test_an_address_that_is_no_address_is_left_out_not_a_failure(odd: str) -> None:
    entry = audit_record(action="login.failed", ip=odd)
    entry.refresh_from_db()
    assert entry.ip is None


@pytest.mark.django_db
def test_a_bracketed_ipv6_address_is_kept() -> None:
    entry = audit_record(action="login.failed", ip="[2001:db8::1]")
    entry.refresh_from_db()
    assert entry.ip == "2001:db8::1"


@pytest.mark.django_db
def test_long_values_are_cut_not_refused() -> None:
    entry = audit_record(action="x." + "y" * 80, actor="a" * 300, subject="s" * 500)
    entry.refresh_from_db()
    assert (len(entry.action), len(entry.actor), len(entry.subject)) == (50, 150, 200)


@pytest.mark.django_db
def test_an_action_rolled_back_leaves_no_entry(vessel_a: Vessel) -> None:
    with pytest.raises(RuntimeError), transaction.atomic():
        vessel_key_issue(vessel=vessel_a, label="never")
        raise RuntimeError("the caller failed after the issue")
    assert not AuditEntry.objects.exists()
    assert not vessel_a.keys.exists()


@pytest.mark.django_db
def test_entries_are_kept_when_their_vessel_is_deleted(vessel_a: Vessel) -> None:
    key, _raw = vessel_key_issue(vessel=vessel_a, label="boat A", created_by="alice")
    Vessel.objects.filter(pk=vessel_a.pk).delete()
    entry = AuditEntry.objects.get()
    assert (entry.action, entry.vessel, entry.actor) == ("key.issued", "spab", "alice")
    assert entry.subject == f"{key.prefix}… (boat A) of SPAB"
