"""The operator's map pages: who sees them, and what frame the server hands their scripts."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import pytest
from django.contrib.auth.models import User
from django.test import Client

from edge_client.contract.status import Status
from fleet.map_actions import map_actions
from fleet.maps import last_stretch_range
from telemetry.models import SensorChannel
from telemetry.services import fix_ingest, sensor_channel_save
from tests.conftest import make_user
from vessels.models import Mission, Vessel
from vessels.services import mission_save, mission_save_items, vessel_create

pytestmark = pytest.mark.django_db


def client_for(user: User) -> Client:
    client = Client()
    client.force_login(user)
    return client


def page_config(html: str, script_id: str) -> dict:
    start = html.index(f'<script id="{script_id}" type="application/json">') + len(
        f'<script id="{script_id}" type="application/json">'
    )
    return json.loads(html[start : html.index("</script>", start)])


def fleet_map_scripts() -> str:
    """The fleet map's own scripts: the map and its command actions."""
    static = Path(__file__).resolve().parents[2] / "fleet/static/fleet"
    return "".join((static / name).read_text() for name in ("fleet_map.js", "fleet_commands.js"))


def test_the_admin_index_opens_on_the_fleet_map(operator_user: User) -> None:
    html = client_for(operator_user).get("/admin/").content.decode()
    assert 'id="fleet-map"' in html and "fleet/fleet_map.js" in html
    assert html.index('id="fleet-map"') < html.index('id="content-main"')  # above the app list


def test_the_fleet_map_offers_the_catalog_actions_of_each_vessel_kind(operator_user: User) -> None:
    config = page_config(
        client_for(operator_user).get("/admin/").content.decode(), "fleet-map-config"
    )
    assert config["canCommand"] is True
    assert [a["kind"] for a in config["actions"]["mavlink"]] == [
        "move_to",
        "hold",
        "resume",
        "return_home",
    ]
    assert [a["kind"] for a in config["actions"]["wave_glider"]] == ["fhead", "hold", "light"]
    assert config["fleetUrl"] == "/api/v1/fleet/"
    assert config["commandsUrl"] == "/api/v1/vessels/__slug__/commands/"
    assert config["trackUrl"] == "/fleet/vessels/__slug__/track/"


def test_each_map_action_takes_its_input_the_way_its_catalog_params_ask() -> None:
    by_kind = {a["kind"]: a for a in map_actions("wave_glider") + map_actions("mavlink")}
    assert by_kind["move_to"]["input"] == "point"
    assert by_kind["fhead"] == {
        "kind": "fhead",
        "label": "Fixed heading",
        "input": "bearing",
        "param": "bearing",
        "min": 0,
        "max": 359,
    }
    script = fleet_map_scripts()
    assert "359" not in script  # the typed heading's range comes with the action
    assert by_kind["light"]["input"] == "choice" and by_kind["light"]["choices"] == ["on", "off"]
    assert by_kind["hold"]["input"] == "none"


def test_an_operator_without_the_add_command_permission_gets_no_buttons(db: None) -> None:
    watcher = make_user("carol", ["vessels.view_vessel", "commands.view_command"])
    config = page_config(client_for(watcher).get("/admin/").content.decode(), "fleet-map-config")
    assert config["canCommand"] is False
    assert config["actions"] == {"mavlink": [], "wave_glider": []}
    assert config["trackUrl"] == ""  # no telemetry.view_fix: no track link either


def test_an_operator_without_the_add_command_permission_gets_403_from_the_map_api(
    db: None, vessel_a: Vessel
) -> None:
    watcher = make_user("carol", ["vessels.view_vessel", "commands.view_command"])
    client = client_for(watcher)
    answer = client.post(
        f"/api/v1/vessels/{vessel_a.slug}/commands/",
        {"kind": "hold", "params": {}},
        content_type="application/json",
    )
    assert answer.status_code == 403
    assert vessel_a.commands.count() == 0


def test_a_user_without_the_view_vessel_permission_sees_no_fleet_map(readonly_user: User) -> None:
    html = client_for(readonly_user).get("/admin/").content.decode()
    assert 'id="fleet-map"' not in html


def test_the_map_pages_carry_the_sensor_channels_labels_and_units(
    operator_user: User, vessel_a: Vessel
) -> None:
    sensor_channel_save(
        channel=SensorChannel(key="water_temp_c", label="Water temperature", unit="°C")
    )
    client = client_for(operator_user)
    fleet = page_config(client.get("/admin/").content.decode(), "fleet-map-config")
    track = page_config(
        client.get(f"/fleet/vessels/{vessel_a.slug}/track/").content.decode(), "track-config"
    )
    for config in (fleet, track):
        assert config["channels"]["water_temp_c"]["label"] == "Water temperature"
        assert config["channels"]["water_temp_c"]["unit"] == "°C"
        assert config["channels"]["battery_v"] == {"label": "Battery", "unit": "V"}


def test_the_track_page_needs_a_login(vessel_a: Vessel) -> None:
    answer = Client().get(f"/fleet/vessels/{vessel_a.slug}/track/")
    assert answer.status_code == 302 and "/admin/login/" in answer["Location"]


def test_the_track_page_is_403_without_the_view_permissions(
    readonly_user: User, vessel_a: Vessel
) -> None:
    client = client_for(readonly_user)
    assert client.get(f"/fleet/vessels/{vessel_a.slug}/track/").status_code == 403
    # The same answer for a vessel that does not exist: no probing of slugs.
    assert client.get("/fleet/vessels/no-such-boat/track/").status_code == 403


def test_the_track_page_shows_the_vessels_track_frame(
    operator_user: User, vessel_a: Vessel
) -> None:
    client = client_for(operator_user)
    answer = client.get(f"/fleet/vessels/{vessel_a.slug}/track/")
    html = answer.content.decode()
    assert answer.status_code == 200
    config = page_config(html, "track-config")
    assert config["trackUrl"] == "/api/v1/vessels/spab/track/"
    assert config["seriesUrl"] == "/api/v1/vessels/spab/series/"
    assert config["nearestUrl"] == "/api/v1/vessels/spab/fixes/nearest/"
    assert "fleet/vendor/uplot/uPlot.iife.min.js" in html and 'id="track-map"' in html
    assert client.get("/fleet/vessels/no-such-boat/track/").status_code == 404


def fixes_every(vessel: Vessel, start: dt.datetime, end: dt.datetime, step_s: int) -> None:
    records, t = [], start
    while t <= end:
        records.append({"time": t.isoformat(), "lat": -32.05, "lon": 115.7})
        t += dt.timedelta(seconds=step_s)
    fix_ingest(vessel=vessel, records=records)


def test_the_track_page_opens_on_the_vessels_last_run_of_reports(
    operator_user: User, vessel_a: Vessel
) -> None:
    client = client_for(operator_user)
    url = f"/fleet/vessels/{vessel_a.slug}/track/"
    # No fixes: the last 24 h from now.
    html = client.get(url).content.decode()
    assert page_config(html, "track-config")["lastStretch"] is None
    assert 'data-default="24h"' in html
    # A day of reports, 16 silent hours (the period is 10 s), then three hours ending at
    # 09:41:20: the page opens on those three hours, in whole minutes, the newest fix inside.
    newest = dt.datetime(2026, 11, 20, 9, 41, 20, tzinfo=dt.UTC)
    older_end = newest - dt.timedelta(hours=19)
    fixes_every(vessel_a, older_end - dt.timedelta(hours=24), older_end, 60)
    fixes_every(vessel_a, newest - dt.timedelta(hours=3), newest, 10)
    html = client.get(url).content.decode()
    assert 'data-default="last"' in html
    assert page_config(html, "track-config")["lastStretch"] == {
        "from": "2026-11-20T06:41:00Z",
        "to": "2026-11-20T09:42:00Z",
    }


def test_the_last_run_of_reports_is_at_most_24_hours_and_at_least_10_minutes(
    vessel_a: Vessel,
) -> None:
    newest = dt.datetime(2026, 11, 20, 9, 41, 20, tzinfo=dt.UTC)
    fixes_every(vessel_a, newest - dt.timedelta(hours=30), newest, 30)
    assert last_stretch_range(vessel_a) == (
        dt.datetime(2026, 11, 19, 9, 41, tzinfo=dt.UTC),
        dt.datetime(2026, 11, 20, 9, 42, tzinfo=dt.UTC),
    )
    lone = vessel_create(slug="lone", name="Lone", kind="mavlink")
    fixes_every(lone, newest, newest, 10)  # one fix
    assert last_stretch_range(lone) == (
        dt.datetime(2026, 11, 20, 9, 32, tzinfo=dt.UTC),
        dt.datetime(2026, 11, 20, 9, 42, tzinfo=dt.UTC),
    )


def test_an_empty_tiles_url_means_no_tile_layer(
    operator_user: User, settings, vessel_a: Vessel
) -> None:
    settings.MAP_TILES_URL = ""
    html = client_for(operator_user).get(f"/fleet/vessels/{vessel_a.slug}/track/").content.decode()
    assert page_config(html, "map-config")["tiles_url"] == ""
    settings.MAP_TILES_URL = "http://tiles.local/{z}/{x}/{y}.png"
    html = client_for(operator_user).get(f"/fleet/vessels/{vessel_a.slug}/track/").content.decode()
    assert page_config(html, "map-config")["tiles_url"] == "http://tiles.local/{z}/{x}/{y}.png"


def test_the_mission_page_carries_the_planner_over_the_item_rows(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    mission = mission_save(mission=Mission(name="Bay", vessel=vessel_a))
    mission_save_items(
        mission=mission,
        items=[{"lat": -31.98, "lon": 115.82, "hold_s": 5, "radius_m": 3}],
    )
    html = admin_ui.get(f"/admin/vessels/mission/{mission.pk}/change/").content.decode()
    assert 'id="mission-map"' in html and "vessels/planner.js" in html
    assert 'data-lat="-31.98"' in html and 'name="items-0-lat"' in html
    assert admin_ui.get("/admin/vessels/mission/add/").status_code == 200


def test_the_mission_page_sends_the_saved_mission_to_its_vessel(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    mission = mission_save(mission=Mission(name="Bay", vessel=vessel_a))
    mission_save_items(
        mission=mission,
        items=[
            {"lat": -31.98, "lon": 115.82, "hold_s": 0, "radius_m": 3},
            {"lat": -31.97, "lon": 115.83, "hold_s": 0, "radius_m": 3},
        ],
    )
    html = admin_ui.get(f"/admin/vessels/mission/{mission.pk}/change/").content.decode()
    assert "Send to SPAB" in html
    # What the button's form posts: the route on screen as planner.js confirmed it, and the
    # version of the mission the page was rendered from.
    shown = {"end": "stop", "items": mission.item_dicts()}
    mission.refresh_from_db()
    answer = admin_ui.post(
        f"/admin/vessels/mission/{mission.pk}/send/",
        {"confirmed": json.dumps(shown), "updated_at": mission.updated_at.isoformat()},
        follow=True,
    )
    assert "queued as command" in answer.content.decode()
    command = vessel_a.commands.get()
    assert command.kind == "mission" and len(command.params["items"]) == 2


def test_a_template_mission_or_an_operator_who_may_not_command_gets_no_send_button(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    template = mission_save(mission=Mission(name="Any boat"))
    html = admin_ui.get(f"/admin/vessels/mission/{template.pk}/change/").content.decode()
    assert "send-mission" not in html
    planner = make_user(
        "pat", ["vessels.view_vessel", "vessels.view_mission", "vessels.change_mission"]
    )
    mission = mission_save(mission=Mission(name="Bay", vessel=vessel_a))
    html = client_for(planner).get(f"/admin/vessels/mission/{mission.pk}/change/")
    assert html.status_code == 200 and "send-mission" not in html.content.decode()


def test_a_vessels_admin_page_links_to_its_track(admin_ui: Client, vessel_a: Vessel) -> None:
    html = admin_ui.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/").content.decode()
    assert f'href="/fleet/vessels/{vessel_a.slug}/track/"' in html


def test_the_fleet_map_takes_command_status_names_from_the_server(
    operator_user: User, vessel_a: Vessel
) -> None:
    fleet = page_config(
        client_for(operator_user).get("/admin/").content.decode(), "fleet-map-config"
    )
    assert fleet["statuses"] == {
        "unfinished": ["queued", "sent", "acknowledged"],
        "cancellable": ["queued", "sent"],
    }
    script = fleet_map_scripts()
    assert not [s for s in Status if f'"{s.value}"' in script]  # no copy of the names left
