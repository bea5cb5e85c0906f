"""Vessel keys: shown once, stored as a hash, revocable, use recorded at most once a minute."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from django.utils import timezone
from rest_framework.exceptions import AuthenticationFailed
from rest_framework.test import APIClient

from vessels.auth import key_lookup
from vessels.keys import KEY_PREFIX, PREFIX_SHOWN, generate_key, hash_key
from vessels.models import Vessel, VesselKey
from vessels.services import vessel_key_issue, vessel_key_revoke, vessel_key_touch

pytestmark = pytest.mark.django_db

COMMANDS = "/api/v1/boat/commands/"


def test_generated_keys_are_long_random_and_recognisable() -> None:
    keys = {generate_key() for _ in range(50)}
    assert len(keys) == 50
    assert all(k.startswith(KEY_PREFIX) and len(k) >= 40 for k in keys)


def test_the_hash_is_sha256_hex_and_stable() -> None:
    assert hash_key("ssk_x") == hash_key("ssk_x")
    assert len(hash_key("ssk_x")) == 64
    assert hash_key("ssk_x") != hash_key("ssk_y")
    hash_key("\udcff")  # a lone surrogate from a garbled header does not crash hashing


def test_a_new_key_is_returned_once_and_only_its_hash_is_stored(vessel_a: Vessel) -> None:
    key, raw = vessel_key_issue(vessel=vessel_a, label="pi", created_by="alice")
    key.refresh_from_db()
    assert key.key_hash == hash_key(raw)
    assert key.prefix == raw[:PREFIX_SHOWN]
    assert (key.label, key.created_by, key.vessel) == ("pi", "alice", vessel_a)
    stored = [str(v) for v in VesselKey.objects.filter(pk=key.pk).values().get().values()]
    assert raw not in stored
    assert all(raw not in value for value in stored)
    assert raw not in str(key)
    assert key.is_active


def test_each_issue_makes_a_different_key(vessel_a: Vessel) -> None:
    (_, first), (_, second) = vessel_key_issue(vessel=vessel_a), vessel_key_issue(vessel=vessel_a)
    assert first != second
    assert vessel_a.keys.count() == 2


def test_a_key_authenticates_its_own_vessel(vessel_a: Vessel, key_a: str) -> None:
    assert key_lookup(key_a).vessel == vessel_a


@pytest.mark.parametrize("raw", ["", "ssk_nope", "x" * 201])
def test_an_unknown_key_is_refused(vessel_a: Vessel, key_a: str, raw: str) -> None:
    with pytest.raises(AuthenticationFailed, match="Invalid vessel key"):
        key_lookup(raw)


def test_a_revoked_key_is_refused_at_once(vessel_a: Vessel) -> None:
    key, raw = vessel_key_issue(vessel=vessel_a)
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=f"Api-Key {raw}")
    assert client.get(COMMANDS).status_code == 200
    vessel_key_revoke(key=key)
    key.refresh_from_db()
    assert key.revoked_at is not None
    assert not key.is_active
    assert client.get(COMMANDS).status_code == 401
    with pytest.raises(AuthenticationFailed, match="revoked"):
        key_lookup(raw)


def test_revoking_keeps_the_first_revocation_time(vessel_a: Vessel) -> None:
    key, _ = vessel_key_issue(vessel=vessel_a)
    first = timezone.now() - dt.timedelta(days=1)
    vessel_key_revoke(key=key, now=first)
    vessel_key_revoke(key=key)
    key.refresh_from_db()
    assert key.revoked_at == first


def test_revoking_one_key_leaves_the_others(vessel_a: Vessel, key_a: str) -> None:
    other, _ = vessel_key_issue(vessel=vessel_a)
    vessel_key_revoke(key=other)
    assert key_lookup(key_a).vessel == vessel_a


def test_key_use_is_recorded_at_most_once_per_interval(vessel_a: Vessel, settings: Any) -> None:
    settings.KEY_TOUCH_INTERVAL_S = 60
    key, _ = vessel_key_issue(vessel=vessel_a)
    t0 = timezone.now()

    vessel_key_touch(key=key, now=t0)
    key.refresh_from_db()
    vessel_a.refresh_from_db()
    assert key.last_used_at == vessel_a.last_seen_at == t0

    vessel_key_touch(key=key, now=t0 + dt.timedelta(seconds=59))
    key.refresh_from_db()
    assert key.last_used_at == t0  # throttled: no write

    vessel_key_touch(key=key, now=t0 + dt.timedelta(seconds=60))
    key.refresh_from_db()
    vessel_a.refresh_from_db()
    assert key.last_used_at == vessel_a.last_seen_at == t0 + dt.timedelta(seconds=60)


def test_authenticated_requests_touch_the_key_without_writing_on_every_poll(
    vessel_a: Vessel,
    key_a: str,
    boat_a: APIClient,
    settings: Any,
    django_assert_max_num_queries: Any,
) -> None:
    settings.KEY_TOUCH_INTERVAL_S = 3600
    assert boat_a.get(COMMANDS).status_code == 200
    key = VesselKey.objects.get(key_hash=hash_key(key_a))
    first_use = key.last_used_at
    assert first_use is not None
    response = boat_a.get(COMMANDS)
    etag = response["ETag"]
    # An unchanged poll within the interval: the key lookup and nothing else.
    with django_assert_max_num_queries(1):
        assert boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=etag).status_code == 304
    key.refresh_from_db()
    assert key.last_used_at == first_use


def test_an_inactive_vessels_key_is_refused(vessel_a: Vessel, key_a: str) -> None:
    Vessel.objects.filter(pk=vessel_a.pk).update(active=False)
    with pytest.raises(AuthenticationFailed, match="not active"):
        key_lookup(key_a)
