"""The vessel, key and mission admins (vessels.admin)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
from django.core.files.uploadedfile import SimpleUploadedFile
from django.test import Client

from tests.conftest import make_user
from vessels.keys import hash_key
from vessels.missions import MISSION_MAX_ITEMS
from vessels.models import Mission, Vessel, VesselKey
from vessels.services import mission_save, mission_save_items

pytestmark = pytest.mark.django_db


def test_it_lists_vessels_with_status_position_and_battery(
    admin_ui: Client, reported: Vessel, vessel_b: Vessel
) -> None:
    page = admin_ui.get("/admin/vessels/vessel/").content.decode()
    assert "SPAB 2" in page and "never seen" in page
    # Decimal degrees, the chart form on hover (one position format, vessels.display).
    assert '<span title="31°57.030′S 115°51.630′E">-31.95050°, 115.86050°</span>' in page
    assert "12.34" in page


def test_it_filters_vessels_by_status(admin_ui: Client, reported: Vessel, vessel_b: Vessel) -> None:
    page = admin_ui.get("/admin/vessels/vessel/?status=never+seen").content.decode()
    assert "SPAB 2" in page and ">SPAB<" not in page


def test_issuing_a_key_shows_it_once_and_stores_only_its_hash(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    response = admin_ui.post(
        "/admin/vessels/vesselkey/add/", {"vessel": vessel_a.pk, "label": "pi"}
    )
    assert response.status_code == 200
    assert "no-store" in response["Cache-Control"]
    raw = re.search(r'id="vessel-key"[^>]*>(ssk_[^<]+)<', response.content.decode()).group(1)
    key = VesselKey.objects.get(vessel=vessel_a)
    assert key.key_hash == hash_key(raw) and key.label == "pi"
    assert raw not in admin_ui.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/").content.decode()


def test_the_revoke_action_revokes_keys(admin_ui: Client, key_a: str) -> None:
    key = VesselKey.objects.get()
    admin_ui.post("/admin/vessels/vesselkey/", {"action": "revoke", "_selected_action": [key.pk]})
    key.refresh_from_db()
    assert key.revoked_at is not None


def test_it_creates_a_vessel_through_the_form(admin_ui: Client) -> None:
    response = admin_ui.post(
        "/admin/vessels/vessel/add/",
        {
            "name": "Third",
            "slug": "third",
            "kind": "mavlink",
            "active": "on",
            "telemetry_period_s": 30,
            "cruise_speed_mps": 2.0,
            "notes": "",
        },
    )
    assert response.status_code == 302
    third = Vessel.objects.get(slug="third")
    assert (third.telemetry_period_s, third.cruise_speed_mps) == (30, 2.0)


def test_the_mission_admin_saves_items_in_order(admin_ui: Client, vessel_a: Vessel) -> None:
    data = {
        "name": "Survey",
        "vessel": vessel_a.pk,
        "end": "stop",
        "notes": "",
        "items-TOTAL_FORMS": 2,
        "items-INITIAL_FORMS": 0,
        "items-0-seq": 2,
        "items-0-lat": -31.91,
        "items-0-lon": 115.81,
        "items-0-hold_s": 0,
        "items-1-seq": 1,
        "items-1-lat": -31.90,
        "items-1-lon": 115.80,
        "items-1-hold_s": 5,
    }
    assert admin_ui.post("/admin/vessels/mission/add/", data).status_code == 302
    mission = Mission.objects.get()
    assert [(i.seq, i.lat) for i in mission.items.all()] == [(1, -31.90), (2, -31.91)]


def test_a_vessels_slug_cannot_be_changed_once_created(admin_ui: Client, vessel_a: Vessel) -> None:
    admin_ui.post(
        f"/admin/vessels/vessel/{vessel_a.pk}/change/",
        {
            "name": "Renamed",
            "slug": "other",
            "kind": "mavlink",
            "active": "on",
            "telemetry_period_s": 10,
            "cruise_speed_mps": 1.5,
            "notes": "",
            "keys-TOTAL_FORMS": 0,
            "keys-INITIAL_FORMS": 0,
        },
    )
    vessel_a.refresh_from_db()
    assert (vessel_a.name, vessel_a.slug) == ("Renamed", "spab")


# --- missions: import, export, route figures, checks on save ---

FILES = Path(__file__).parent / "files"


def mission_form(vessel: Vessel, *points: tuple[float, float], **fields: object) -> dict:
    data: dict[str, object] = {
        "name": "Survey",
        "vessel": vessel.pk,
        "end": "stop",
        "home_lat": "",
        "home_lon": "",
        "notes": "",
        "items-TOTAL_FORMS": len(points),
        "items-INITIAL_FORMS": 0,
        **fields,
    }
    for n, (lat, lon) in enumerate(points):
        data.update({f"items-{n}-seq": n + 1, f"items-{n}-lat": lat, f"items-{n}-lon": lon})
        data[f"items-{n}-hold_s"] = 0
    return data


def test_the_mission_list_links_to_the_import_page(admin_ui: Client) -> None:
    page = admin_ui.get("/admin/vessels/mission/").content.decode()
    assert 'href="/admin/vessels/mission/import/"' in page and "Import mission file" in page


def test_importing_a_file_with_unsupported_items_names_them_and_imports_nothing(
    admin_ui: Client,
) -> None:
    with (FILES / "survey.plan").open("rb") as file:
        response = admin_ui.post("/admin/vessels/mission/import/", {"file": file})
    assert response.status_code == 200
    assert "item 4 (ComplexItem survey)" in response.content.decode()
    assert not Mission.objects.exists()


def test_importing_with_skip_reports_the_skipped_items_on_the_new_mission(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    with (FILES / "survey.plan").open("rb") as file:
        response = admin_ui.post(
            "/admin/vessels/mission/import/",
            {"file": file, "vessel": vessel_a.pk, "name": "", "skip_unsupported": "on"},
            follow=True,
        )
    mission = Mission.objects.get()
    assert response.redirect_chain[-1][0] == f"/admin/vessels/mission/{mission.pk}/change/"
    page = response.content.decode()
    assert "Imported survey: 3 waypoint(s)." in page
    assert "Skipped item 4 (ComplexItem survey)" in page
    assert (mission.vessel, mission.end, mission.home) == (
        vessel_a,
        "return_home",
        (-31.9852, 115.8327),
    )


def test_the_mission_page_shows_legs_totals_and_export_links(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    mission = mission_save(mission=Mission(name="Bay run", vessel=vessel_a))
    mission_save_items(
        mission=mission,
        items=[{"lat": -32.0, "lon": 115.0}, {"lat": -32.0 + 900 / 111_195, "lon": 115.0}],
    )
    page = admin_ui.get(f"/admin/vessels/mission/{mission.pk}/change/").content.decode()
    assert "<td>1 → 2</td><td>900 m</td><td>0°</td><td>1.5 m/s (2.9 kn)</td><td>10 min</td>" in page
    assert '<b id="mission-route-total">2 waypoints · 900 m · 10 min</b>' in page
    for fmt in ("plan", "waypoints", "geojson"):
        assert f"/admin/vessels/mission/{mission.pk}/export/{fmt}/" in page
    assert 'name="items-0-speed_mps"' in page


def test_an_export_link_downloads_the_file(admin_ui: Client, vessel_a: Vessel) -> None:
    mission = mission_save(mission=Mission(name="Bay run", vessel=vessel_a, end="loop"))
    mission_save_items(mission=mission, items=[{"lat": -32.0, "lon": 115.0}])
    response = admin_ui.get(f"/admin/vessels/mission/{mission.pk}/export/waypoints/")
    assert response["Content-Disposition"] == 'attachment; filename="bay-run.waypoints"'
    assert response.content.startswith(b"QGC WPL 110\r\n")
    assert admin_ui.get(f"/admin/vessels/mission/{mission.pk}/export/kml/").status_code == 404


def test_saving_a_mission_that_fails_its_checks_keeps_it_and_warns(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    data = mission_form(vessel_a, (-32.0, 115.0), (-32.0, 115.0))
    response = admin_ui.post("/admin/vessels/mission/add/", data, follow=True)
    page = response.content.decode()
    assert "Saved, but it cannot be sent yet: waypoints 1 and 2 are the same point" in page
    assert Mission.objects.get().items.count() == 2


def test_saving_a_glider_mission_warns_that_gliders_cannot_run_it(
    admin_ui: Client, glider: Vessel
) -> None:
    # The catalog's checks too (fleet.admin): the whole set a send makes.
    data = mission_form(glider, (-32.0, 115.0))
    page = admin_ui.post("/admin/vessels/mission/add/", data, follow=True).content.decode()
    assert "cannot be sent yet: mission is not available for wave_glider vessels" in page


def test_the_import_page_needs_the_add_permission(client: Client, readonly_user: object) -> None:
    client.force_login(readonly_user)
    assert client.get("/admin/vessels/mission/import/").status_code == 403


# --- missions for a user who may not see vessels: templates only, as the API ---

MISSION_ONLY_PERMS = [
    "vessels.view_mission",
    "vessels.add_mission",
    "vessels.change_mission",
    "vessels.view_missionitem",
    "vessels.add_missionitem",
    "vessels.change_missionitem",
    "vessels.delete_missionitem",
]


@pytest.fixture
def mission_only(client: Client, db: None) -> Client:
    client.force_login(make_user("mo", MISSION_ONLY_PERMS))
    return client


def test_a_user_who_may_not_see_vessels_sees_only_template_missions_in_the_admin(
    mission_only: Client, reported: Vessel
) -> None:
    secret = mission_save(mission=Mission(name="Secret run", vessel=reported))
    template = mission_save(mission=Mission(name="Template run"))
    listing = mission_only.get("/admin/vessels/mission/").content.decode()
    assert "Template run" in listing
    assert "Secret run" not in listing and reported.name not in listing
    assert mission_only.get(f"/admin/vessels/mission/{secret.pk}/change/").status_code == 302
    page = mission_only.get(f"/admin/vessels/mission/{template.pk}/change/").content.decode()
    assert "Secret run" not in page
    assert f'data-name="{reported.name}"' not in page and str(reported.last_fix["lat"]) not in page
    assert f'<option value="{reported.pk}"' not in page


def test_a_user_who_may_not_see_vessels_cannot_give_a_mission_a_vessel(
    mission_only: Client, vessel_a: Vessel
) -> None:
    add = mission_only.get("/admin/vessels/mission/add/").content.decode()
    assert 'data-name="SPAB"' not in add and f'<option value="{vessel_a.pk}"' not in add
    data = mission_form(vessel_a, (-32.0, 115.0))
    response = mission_only.post("/admin/vessels/mission/add/", data)
    assert response.status_code == 200 and "Select a valid choice" in response.content.decode()
    import_page = mission_only.get("/admin/vessels/mission/import/").content.decode()
    assert "SPAB" not in import_page
    with (FILES / "survey.plan").open("rb") as file:
        response = mission_only.post(
            "/admin/vessels/mission/import/",
            {"file": file, "vessel": vessel_a.pk, "skip_unsupported": "on"},
        )
    assert "Select a valid choice" in response.content.decode()
    assert not Mission.objects.exists()


def test_the_admin_refuses_a_mission_past_the_item_limit_on_the_page(
    admin_ui: Client, vessel_a: Vessel, settings: Any
) -> None:
    settings.DATA_UPLOAD_MAX_NUMBER_FIELDS = 10_000  # 4 fields a row; Django's default is 1,000
    points = [(-32.0, 115.0 + n / 1000) for n in range(MISSION_MAX_ITEMS + 1)]
    response = admin_ui.post("/admin/vessels/mission/add/", mission_form(vessel_a, *points))
    assert response.status_code == 200
    assert f"Please submit at most {MISSION_MAX_ITEMS} forms" in response.content.decode()
    assert not Mission.objects.exists()


def test_importing_a_file_past_the_item_limit_is_refused_on_the_form(admin_ui: Client) -> None:
    rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t-31.98\t115.83\t0\t1"]
    rows += [
        f"{n}\t0\t3\t16\t0\t0\t0\t0\t-31.98\t{115.83 + n / 1e4:.6f}\t0\t1" for n in range(1, 601)
    ]
    file = SimpleUploadedFile("long.waypoints", ("\n".join(rows) + "\n").encode())
    response = admin_ui.post("/admin/vessels/mission/import/", {"file": file})
    assert response.status_code == 200
    assert "the file has 600 waypoints; a mission holds at most 500" in response.content.decode()
    assert not Mission.objects.exists()


def test_an_import_declared_too_big_is_refused_on_the_form_before_it_is_read(
    admin_ui: Client,
) -> None:
    with (FILES / "survey.plan").open("rb") as file:  # small: only the declared length refuses
        response = admin_ui.post(
            "/admin/vessels/mission/import/",
            {"file": file, "skip_unsupported": "on"},
            CONTENT_LENGTH=str(20 * 1024 * 1024),
        )
    assert response.status_code == 200
    assert "the upload is 21.0 MB; a mission file is at most 5.2 MB" in response.content.decode()
    assert not Mission.objects.exists()
