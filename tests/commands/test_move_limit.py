"""How far a move_to may send a vessel (issue 16 §2): at most its limit from the last fix,
refused alike by the catalog, the service, the admin form and the operator API."""

from __future__ import annotations

import pytest
from django.contrib.auth.models import User
from django.test import Client
from django.utils import timezone
from rest_framework.test import APIClient

from commands import catalog
from commands.errors import CatalogError
from commands.models import Command
from commands.services import command_enqueue, vessel_context
from edge_client.contract.geo import distance_m
from telemetry.services import fix_ingest
from tests.conftest import make_user
from tests.support import commands_url
from vessels.models import Vessel

pytestmark = pytest.mark.django_db

PERTH = (-31.9505, 115.8605)
LONDON = (51.5074, -0.1278)
# 733 km inland from Perth, as the map click in the issue (north-east, into the desert).
INLAND = (-27.1022, 121.0)
NEARBY = (-31.9600, 115.8500)  # 1.4 km from PERTH


def context(position: tuple[float, float] | None, limit: float = 5000) -> catalog.VesselContext:
    return catalog.VesselContext(
        name="SPAB", position=position, move_to_max_m=limit, limit_source="MOVE_TO_MAX_M"
    )


def move_to(target: tuple[float, float]) -> dict[str, float]:
    return {"lat": target[0], "lon": target[1]}


@pytest.fixture
def at_perth(vessel_a: Vessel, make_fix) -> Vessel:
    """Boat A, having reported a fix in Perth."""
    fix_ingest(
        vessel=vessel_a,
        records=[make_fix(time=timezone.now().isoformat(), lat=PERTH[0], lon=PERTH[1])],
    )
    vessel_a.refresh_from_db()
    return vessel_a


# --- the catalog (pure) ---


def test_the_catalog_takes_a_move_to_within_the_limit() -> None:
    valid = catalog.validate("move_to", move_to(NEARBY), vessel=context(PERTH))
    assert valid.params == move_to(NEARBY)


def test_the_catalog_refuses_a_move_to_beyond_the_limit_naming_distance_and_limit() -> None:
    metres = distance_m(*PERTH, *INLAND)
    assert round(metres / 1000, 1) == 733.2
    with pytest.raises(CatalogError) as err:
        catalog.validate("move_to", move_to(INLAND), vessel=context(PERTH))
    assert err.value.message == (
        f"move_to target is {metres / 1000:.1f} km from SPAB's last fix; "
        "the limit is 5.0 km (MOVE_TO_MAX_M)"
    )


def test_the_limit_is_inclusive_and_measured_on_the_sphere() -> None:
    metres = distance_m(*PERTH, *NEARBY)
    catalog.validate("move_to", move_to(NEARBY), vessel=context(PERTH, limit=metres + 0.01))
    with pytest.raises(CatalogError, match="the limit is 1.4 km"):
        catalog.validate("move_to", move_to(NEARBY), vessel=context(PERTH, limit=metres - 1))


def test_without_a_last_fix_a_move_to_is_refused_since_its_distance_is_unknown() -> None:
    with pytest.raises(CatalogError) as err:
        catalog.validate("move_to", move_to(NEARBY), vessel=context(None))
    assert err.value.message == (
        "SPAB has not reported a fix yet, so how far the move_to target is cannot be checked; "
        "the limit is 5.0 km (MOVE_TO_MAX_M)"
    )


def test_a_limit_of_zero_turns_the_check_off() -> None:
    catalog.validate("move_to", move_to(LONDON), vessel=context(PERTH, limit=0))
    catalog.validate("move_to", move_to(LONDON), vessel=context(None, limit=0))


def test_only_move_to_is_measured() -> None:
    # A mission's legs have their own limit (MISSION_MAX_LEG_M); a glider waypoint sets a
    # table entry, not a course.
    catalog.validate("hold", {}, vessel=context(None))
    catalog.validate(
        "waypoint", {"index": 1, **move_to(LONDON)}, vessel_kind="wave_glider", vessel=context(None)
    )


# --- the vessel's limit: its own, else the site's ---


def test_a_vessel_without_its_own_limit_takes_the_site_default(vessel_a: Vessel, settings) -> None:
    settings.MOVE_TO_MAX_M = 1234
    found = vessel_context(vessel_a)
    assert (found.move_to_max_m, found.limit_source, found.position) == (
        1234,
        "MOVE_TO_MAX_M",
        None,
    )


def test_a_vessels_own_limit_overrides_the_site_default(at_perth: Vessel, settings) -> None:
    settings.MOVE_TO_MAX_M = 1000
    with pytest.raises(CatalogError, match=r"the limit is 1.0 km \(MOVE_TO_MAX_M\)"):
        command_enqueue(vessel=at_perth, kind="move_to", params=move_to(NEARBY))
    at_perth.move_to_max_m = 2000
    command_enqueue(vessel=at_perth, kind="move_to", params=move_to(NEARBY))
    at_perth.move_to_max_m = 500
    with pytest.raises(CatalogError, match=r"the limit is 500 m \(SPAB's move_to limit\)"):
        command_enqueue(vessel=at_perth, kind="move_to", params=move_to(NEARBY))
    assert Command.objects.count() == 1


def test_the_default_site_limit_is_five_km(settings) -> None:
    assert settings.MOVE_TO_MAX_M == 5000


# --- every way in refuses alike ---


def test_the_operator_api_refuses_perth_to_london(operator: APIClient, at_perth: Vessel) -> None:
    response = operator.post(
        commands_url(), {"kind": "move_to", "params": move_to(LONDON)}, format="json"
    )
    assert response.status_code == 400
    metres = distance_m(*PERTH, *LONDON)
    assert response.json() == {
        "error": "invalid",
        "detail": {
            "params": [
                f"move_to target is {metres / 1000:.1f} km from SPAB's last fix; "
                "the limit is 5.0 km (MOVE_TO_MAX_M)"
            ]
        },
    }
    assert not Command.objects.exists()
    nearby = operator.post(
        commands_url(), {"kind": "move_to", "params": move_to(NEARBY)}, format="json"
    )
    assert nearby.status_code == 201


def test_the_operator_api_refuses_a_move_to_for_a_vessel_never_seen(
    operator: APIClient, vessel_a: Vessel
) -> None:
    response = operator.post(
        commands_url(), {"kind": "move_to", "params": move_to(NEARBY)}, format="json"
    )
    assert response.status_code == 400
    assert "SPAB has not reported a fix yet" in str(response.json()["detail"])
    assert not Command.objects.exists()


def test_the_admin_form_refuses_a_move_to_beyond_the_limit(
    admin_ui: Client, at_perth: Vessel
) -> None:
    response = admin_ui.post(
        "/admin/commands/command/add/",
        {
            "vessel": at_perth.pk,
            "kind": "move_to",
            "move_to__lat": str(INLAND[0]),
            "move_to__lon": str(INLAND[1]),
        },
    )
    assert response.status_code == 200  # the form again, with the error
    page = response.content.decode()
    assert "move_to target is 733.2 km from SPAB" in page
    assert "the limit is 5.0 km (MOVE_TO_MAX_M)" in page
    assert not Command.objects.exists()


# --- the per-vessel setting: admin and operator API ---


def test_the_vessel_admin_sets_the_limit(admin_ui: Client, vessel_a: Vessel) -> None:
    page = admin_ui.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/").content.decode()
    assert 'name="move_to_max_m"' in page
    response = admin_ui.post(
        f"/admin/vessels/vessel/{vessel_a.pk}/change/",
        {
            "name": "SPAB",
            "kind": "mavlink",
            "active": "on",
            "telemetry_period_s": 10,
            "cruise_speed_mps": 1.5,
            "move_to_max_m": "800",
            "notes": "",
            "keys-TOTAL_FORMS": 0,
            "keys-INITIAL_FORMS": 0,
        },
    )
    assert response.status_code == 302
    vessel_a.refresh_from_db()
    assert vessel_a.move_to_max_m == 800


@pytest.fixture
def skipper(db: None) -> APIClient:
    """An operator who may change vessels' settings."""
    user: User = make_user("skipper", ["vessels.view_vessel", "vessels.change_vessel"])
    client = APIClient()
    client.force_authenticate(user)
    return client


def test_the_operator_api_sets_and_clears_a_vessels_limit(
    skipper: APIClient, at_perth: Vessel
) -> None:
    response = skipper.patch("/api/v1/vessels/spab/", {"move_to_max_m": 800}, format="json")
    assert response.status_code == 200
    assert response.json()["move_to_max_m"] == 800
    at_perth.refresh_from_db()
    assert at_perth.move_to_max_m == 800
    assert at_perth.last_fix["lat"] == pytest.approx(PERTH[0])  # the fix is left alone
    with pytest.raises(CatalogError, match=r"the limit is 800 m \(SPAB's move_to limit\)"):
        command_enqueue(vessel=at_perth, kind="move_to", params=move_to(NEARBY))

    response = skipper.patch("/api/v1/vessels/spab/", {"move_to_max_m": None}, format="json")
    assert (response.status_code, response.json()["move_to_max_m"]) == (200, None)
    at_perth.refresh_from_db()
    command_enqueue(vessel=at_perth, kind="move_to", params=move_to(NEARBY))


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"move_to_max_m": -1}, "move_to_max_m"),
        ({"move_to_max_m": 2.5}, "move_to_max_m"),
        ({"move_to_max_m": "far"}, "move_to_max_m"),
        ({"move_to_max_m": 30_000_000}, "move_to_max_m"),
        ({"name": "Renamed"}, "name"),
        ({"move_to_max_m": 10, "slug": "x"}, "slug"),
    ],
)
def test_the_operator_api_refuses_a_bad_limit_by_field(
    skipper: APIClient, vessel_a: Vessel, body: dict, field: str
) -> None:
    response = skipper.patch("/api/v1/vessels/spab/", body, format="json")
    assert response.status_code == 400
    assert set(response.json()["detail"]) == {field}
    vessel_a.refresh_from_db()
    assert (vessel_a.move_to_max_m, vessel_a.name, vessel_a.slug) == (None, "SPAB", "spab")


def test_changing_a_vessels_limit_needs_the_change_right(
    operator: APIClient, vessel_a: Vessel
) -> None:
    response = operator.patch("/api/v1/vessels/spab/", {"move_to_max_m": 0}, format="json")
    assert response.status_code == 403
    vessel_a.refresh_from_db()
    assert vessel_a.move_to_max_m is None
