"""The fleet map's open alerts (`/api/v1/fleet/alerts/`), its fences (in the overlays), and the
vessel's admin page and list showing open alerts."""

from __future__ import annotations

import pytest
from rest_framework.test import APIClient

from alerts.models import AlertState
from tests.alerts.conftest import ALERT_PERMS
from tests.alerts.test_api_rules import open_alert
from tests.conftest import make_user
from tests.vessels.test_fence_geometry import SQUARE, polygon
from vessels.fence_services import fence_create
from vessels.services import vessel_create

pytestmark = pytest.mark.django_db
ALERTS = "/api/v1/fleet/alerts/"
OVERLAYS = "/api/v1/fleet/overlays/"


@pytest.fixture
def watcher(db) -> APIClient:
    """Carol (tests/alerts/conftest.py): every alert and fence right."""
    client = APIClient()
    client.force_authenticate(make_user("carol", ALERT_PERMS))
    return client


def test_the_map_gets_the_active_alerts_of_the_active_fleet(watcher, vessel_a, vessel_b):
    first = open_alert(vessel_a, minutes_ago=10)
    acked = open_alert(vessel_b, minutes_ago=5, state=AlertState.ACKNOWLEDGED)
    open_alert(vessel_a, minutes_ago=60, state=AlertState.RESOLVED)
    retired = vessel_create(slug="old", name="Old")
    retired.active = False
    retired.save()
    open_alert(retired)
    r = watcher.get(ALERTS)
    assert r.status_code == 200
    alerts = r.json()["alerts"]
    assert [(a["id"], a["vessel"], a["state"]) for a in alerts] == [
        (acked.pk, "spab-2", "acknowledged"),
        (first.pk, "spab", "open"),
    ]
    assert alerts[1]["rule"] == "battery rule" and alerts[1]["detail"] == "battery 11.2 V"
    # Nothing new: 304.
    again = watcher.get(ALERTS, HTTP_IF_NONE_MATCH=r["ETag"])
    assert again.status_code == 304


def test_the_alerts_poll_needs_the_right_to_see_alerts(operator, readonly, boat_a):
    for client in (operator, readonly, boat_a):
        assert client.get(ALERTS).status_code == 403


def test_the_overlays_bring_the_fleets_fences(watcher, vessel_a, vessel_b):
    fence_create(name="Everyone's", geometry=polygon(SQUARE))
    fence_create(name="B's", geometry={"type": "Point", "coordinates": [115.7, -32]},
                 radius_m=80, vessel=vessel_b, inclusion=False)  # fmt: skip
    fences = watcher.get(OVERLAYS).json()["fences"]
    assert [(f["name"], f["vessel"], f["inclusion"], f["radius_m"]) for f in fences] == [
        ("B's", "spab-2", False, 80.0),
        ("Everyone's", None, True, None),
    ]


def test_no_fences_without_the_right_to_see_them(operator, vessel_a):
    fence_create(name="Everyone's", geometry=polygon(SQUARE))
    assert operator.get(OVERLAYS).json()["fences"] is None


def test_the_map_page_offers_alerts_to_who_may_see_and_acknowledge_them(client, vessel_a):
    from fleet.maps import fleet_map_config

    class Request:
        def __init__(self, user):
            self.user = user
            self.META = {}
            self.COOKIES = {}

    config = fleet_map_config(Request(make_user("hana", ALERT_PERMS)))
    assert config["alertsUrl"] == ALERTS and config["canAck"] is True
    assert config["ackUrl"] == "/api/v1/alerts/__id__/ack/"
    config = fleet_map_config(Request(make_user("frank", ["vessels.view_vessel"])))
    assert config["alertsUrl"] == "" and config["canAck"] is False


def test_the_vessel_page_and_list_show_open_alerts(admin_ui, vessel_a, vessel_b):
    open_alert(vessel_a)
    page = admin_ui.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/").content.decode()
    assert "Open alerts" in page and "battery 11.2 V" in page and "alert-open" in page
    quiet = admin_ui.get(f"/admin/vessels/vessel/{vessel_b.pk}/change/").content.decode()
    assert "battery 11.2 V" not in quiet
    listed = admin_ui.get("/admin/vessels/vessel/").content.decode()
    assert listed.count('class="alert-count"') == 1


def test_it_is_one_query_for_the_whole_fleet(
    watcher, vessel_a, vessel_b, django_assert_max_num_queries
):
    for vessel in (vessel_a, vessel_b):
        open_alert(vessel)
    client = APIClient()
    client.force_authenticate(make_user("gina", ALERT_PERMS))
    with django_assert_max_num_queries(4):  # the user's permissions, the fleet, the alerts
        assert len(client.get(ALERTS).json()["alerts"]) == 2
