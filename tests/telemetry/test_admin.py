"""The fix and sensor channel admins (telemetry.admin)."""

from __future__ import annotations

import pytest
from django.test import Client

from telemetry.models import Fix
from telemetry.services import fix_ingest
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


def test_the_fix_list_reads_seconds_positions_speeds_and_compact_readings(
    admin_ui: Client, vessel_a: Vessel, make_fix
) -> None:
    from telemetry.models import SensorChannel

    SensorChannel.objects.create(key="humidity", label="Humidity", unit="%")
    readings = {"humidity": 41.0, "mode_number": 4, "armed": 0, "raw_x": 3}
    fix_ingest(
        vessel=vessel_a,
        records=[
            make_fix(time="2026-11-25T14:03:22Z", readings=readings, speed_mps=1.5),
            make_fix(time="2026-11-25T14:03:27Z", readings={**readings, "mode_number": 10}),
        ],
    )
    page = admin_ui.get("/admin/telemetry/fix/").content.decode()
    # Five seconds apart, and they read so.
    assert "2026-11-25 14:03:22 UTC" in page and "2026-11-25 14:03:27 UTC" in page
    assert (
        '<span class="nowrap" title="31°57.030′S 115°51.630′E">-31.95050°, 115.86050°</span>'
        in page
    )
    assert "1.5 m/s (2.9 kn)" in page
    line = "\u00a0· ".join(
        f'<span class="nowrap">{part}</span>'
        for part in ("Mode HOLD", "disarmed", "Battery 12.6 V", "Humidity 41 %", "raw_x 3")
    )
    assert line in page
    assert "Mode AUTO" in page
    assert "mode_number" not in page and "&quot;armed&quot;" not in page  # no raw JSON


def test_a_fix_page_reads_the_same(admin_ui: Client, vessel_a: Vessel, make_fix) -> None:
    fix_ingest(vessel=vessel_a, records=[make_fix(readings={"armed": 1, "mode_number": 15})])
    fix = Fix.objects.get()
    page = admin_ui.get(f"/admin/telemetry/fix/{fix.pk}/change/").content.decode()
    assert "2026-11-23 10:00:00 UTC" in page
    assert "Mode GUIDED" in page and ">armed<" in page
    assert "1.2 m/s (2.3 kn)" in page
