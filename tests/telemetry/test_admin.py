"""The fix and sensor channel admins (telemetry.admin)."""

from __future__ import annotations

import pytest
from django.test import Client

from vessels.models import Vessel

pytestmark = pytest.mark.django_db


def test_the_fix_list_is_cheap_and_filterable(
    admin_ui: Client, reported: Vessel, vessel_b: Vessel
) -> None:
    page = admin_ui.get(f"/admin/telemetry/fix/?vessel={reported.pk}").content.decode()
    assert "-31.9505" in page
    assert admin_ui.get("/admin/telemetry/fix/?recorded=1h").status_code == 200
    assert "Add fix" not in page


@pytest.mark.parametrize("value", ["abc", "1.5", "99999999999999999999999"])
def test_a_malformed_vessel_filter_is_not_a_500(
    admin_ui: Client, reported: Vessel, value: str
) -> None:
    response = admin_ui.get(f"/admin/telemetry/fix/?vessel={value}")
    assert response.status_code in (200, 302)


def test_a_sensor_channel_is_added_and_validated_in_the_admin(admin_ui: Client) -> None:
    from telemetry.models import SensorChannel

    bad = admin_ui.post(
        "/admin/telemetry/sensorchannel/add/", {"key": "water temp", "label": "Water", "unit": "°C"}
    )
    assert bad.status_code == 200 and not SensorChannel.objects.exists()
    good = admin_ui.post(
        "/admin/telemetry/sensorchannel/add/",
        {"key": "water_temp_c", "label": "Water", "unit": "°C", "minimum": 10, "maximum": 30},
    )
    assert good.status_code == 302
    assert SensorChannel.objects.get().key == "water_temp_c"
