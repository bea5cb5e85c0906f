"""Personas for every test (STYLE §16): operators with and without rights, a stranger,
boat A and boat B with their own keys, and a revoked key."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable
from typing import Any

import pytest
from django.contrib.auth.models import Permission, User
from django.core.cache import cache
from django.test import Client
from rest_framework.test import APIClient

from commands.models import Command
from commands.services import command_enqueue
from operators.services import operator_token_issue
from telemetry.services import fix_ingest
from tests.support import BASE, iso
from vessels.models import Vessel
from vessels.services import vessel_create, vessel_key_issue, vessel_key_revoke

OPERATOR_PERMS = [
    "vessels.view_vessel",
    "telemetry.view_fix",
    "commands.view_command",
    "commands.add_command",
    "commands.change_command",
]


@pytest.fixture(autouse=True)
def _allowed_hosts(settings: Any) -> None:
    settings.ALLOWED_HOSTS = ["testserver", "localhost", "127.0.0.1"]


@pytest.fixture(autouse=True)
def _fresh_cache() -> None:
    # Throttle and failed-login counts live in the cache; each test starts from zero.
    cache.clear()


@pytest.fixture(autouse=True)
def _fast_password_hashing(settings: Any) -> None:
    # Each operator persona is a new user; full-strength PBKDF2 costs ~0.3 s per user.
    settings.PASSWORD_HASHERS = ["django.contrib.auth.hashers.MD5PasswordHasher"]


@pytest.fixture(autouse=True)
def _link_tally(settings: Any) -> Any:
    # The boat API's HTTP counts wait in the process (links.http): no test's request writes
    # another test's counts, or adds a timed flush to a test counting its queries. Tests of
    # the counting set LINK_FLUSH_S = 0.
    from links.http import TALLY

    settings.LINK_FLUSH_S = 1e9
    TALLY.clear()
    yield
    TALLY.clear()


@pytest.fixture
def vessel_a(db: None) -> Vessel:
    return vessel_create(slug="spab", name="SPAB", kind="mavlink", telemetry_period_s=10)


@pytest.fixture
def vessel_b(db: None) -> Vessel:
    return vessel_create(slug="spab-2", name="SPAB 2", kind="mavlink")


@pytest.fixture
def glider(db: None) -> Vessel:
    return vessel_create(slug="glider", name="Wave Glider", kind="wave_glider")


@pytest.fixture
def key_a(vessel_a: Vessel) -> str:
    return vessel_key_issue(vessel=vessel_a, label="boat A")[1]


@pytest.fixture
def key_b(vessel_b: Vessel) -> str:
    return vessel_key_issue(vessel=vessel_b, label="boat B")[1]


@pytest.fixture
def revoked_key_a(vessel_a: Vessel) -> str:
    key, raw = vessel_key_issue(vessel=vessel_a, label="old")
    vessel_key_revoke(key=key)
    return raw


def boat_client(raw_key: str) -> APIClient:
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=f"Api-Key {raw_key}")
    return client


@pytest.fixture
def boat_a(key_a: str) -> APIClient:
    return boat_client(key_a)


@pytest.fixture
def boat_b(key_b: str) -> APIClient:
    return boat_client(key_b)


@pytest.fixture
def revoked_boat(revoked_key_a: str) -> APIClient:
    return boat_client(revoked_key_a)


@pytest.fixture
def anonymous() -> APIClient:
    return APIClient()


def make_user(username: str, perms: list[str], *, staff: bool = True) -> User:
    user = User.objects.create_user(
        username, f"{username}@example.org", "pw-" + username, is_staff=staff
    )
    for perm in perms:
        app_label, codename = perm.split(".")
        user.user_permissions.add(
            Permission.objects.get(content_type__app_label=app_label, codename=codename)
        )
    return user


@pytest.fixture
def operator_user(db: None) -> User:
    """Alice: an operator with the rights to read the fleet and command it."""
    return make_user("alice", OPERATOR_PERMS)


@pytest.fixture
def readonly_user(db: None) -> User:
    """Bob: logged in, staff, but without any model permission."""
    return make_user("bob", [])


@pytest.fixture
def operator(operator_user: User) -> APIClient:
    client = APIClient()
    client.force_authenticate(operator_user)
    return client


@pytest.fixture
def session_operator(operator_user: User) -> APIClient:
    """Alice through the browser session."""
    client = APIClient()
    client.force_login(operator_user)
    return client


@pytest.fixture
def token_operator(operator_user: User) -> APIClient:
    """Alice through her personal API token."""
    client = APIClient()
    _token, raw = operator_token_issue(user=operator_user, name="alice's script", expires_in=None)
    client.credentials(HTTP_AUTHORIZATION=f"Token {raw}")
    return client


def give_position(vessel: Vessel, lat: float = -31.9505, lon: float = 115.8605) -> Vessel:
    """Set the vessel's last fix (denormalised, no Fix row, no "seen" time): a move_to is
    measured from it (MOVE_TO_MAX_M) and refused without one. For tests about something else;
    tests of the limit itself ingest real fixes."""
    Vessel.objects.filter(pk=vessel.pk).update(
        last_fix={"time": "2026-11-23T10:00:00+00:00", "lat": lat, "lon": lon}
    )
    vessel.refresh_from_db(fields=["last_fix"])
    return vessel


@pytest.fixture
def command_a(vessel_a: Vessel) -> Command:
    """A queued move_to for boat A (from a last fix 70 m away)."""
    give_position(vessel_a)
    return command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -31.95, "lon": 115.86})


@pytest.fixture
def readonly(readonly_user: User) -> APIClient:
    client = APIClient()
    client.force_authenticate(readonly_user)
    return client


@pytest.fixture
def make_fix() -> Callable[..., dict[str, Any]]:
    """A valid v1 fix record, with any field overridden."""

    def make(**overrides: Any) -> dict[str, Any]:
        record: dict[str, Any] = {
            "time": "2026-11-23T10:00:00Z",
            "lat": -31.9505,
            "lon": 115.8605,
            "heading_deg": 90.0,
            "speed_mps": 1.2,
            "battery_v": 12.6,
            "readings": {"water_temp_c": 19.5},
        }
        record.update(overrides)
        return {k: v for k, v in record.items() if v is not ...}

    return make


@pytest.fixture
def admin_ui(admin_user: User) -> Client:
    client = Client()
    client.force_login(admin_user)
    return client


@pytest.fixture
def reported(vessel_a: Vessel, make_fix) -> Vessel:
    fix_ingest(vessel=vessel_a, records=[make_fix(battery_v=12.34)])
    vessel_a.refresh_from_db()
    return vessel_a


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
