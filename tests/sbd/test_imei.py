"""A vessel's Iridium IMEI: 15 digits, unique, optional; in the admin, the API and
create_vessel."""

from __future__ import annotations

from typing import Any

import pytest
from django.core.exceptions import ValidationError
from django.core.management import CommandError, call_command
from django.test import Client

from vessels.models import Vessel
from vessels.services import vessel_create

pytestmark = pytest.mark.django_db
IMEI = "300434063839690"


def test_create_vessel_takes_an_imei() -> None:
    call_command("create_vessel", "sat-1", "--name", "Sat one", "--imei", IMEI)
    assert Vessel.objects.get(slug="sat-1").imei == IMEI
    call_command("create_vessel", "plain", "--name", "Plain")
    call_command("create_vessel", "plain-2", "--name", "Plain 2")  # no IMEI: many may
    assert Vessel.objects.get(slug="plain").imei is None
    with pytest.raises(CommandError, match="imei"):
        call_command("create_vessel", "sat-2", "--name", "Sat two", "--imei", IMEI)
    with pytest.raises(CommandError, match="15 digits"):
        call_command("create_vessel", "sat-3", "--name", "Sat three", "--imei", "12345")


def test_an_imei_is_15_digits() -> None:
    for bad in ["30043406383969", "3004340638396900", "30043406383969a", "300434063839690\n"]:
        with pytest.raises(ValidationError):
            vessel_create(slug="x", name="X", imei=bad)


def test_the_api_shows_and_changes_it(
    vessel_a: Vessel, operator: Any, admin_client: Client
) -> None:
    url = f"/api/v1/vessels/{vessel_a.slug}/"
    assert operator.get(url).json()["imei"] is None
    answer = admin_client.patch(url, {"imei": IMEI}, content_type="application/json")
    assert answer.status_code == 200 and answer.json()["imei"] == IMEI
    vessel_create(slug="other", name="Other", imei="300434063839691")
    taken = admin_client.patch(url, {"imei": "300434063839691"}, content_type="application/json")
    assert taken.status_code == 400 and "imei" in taken.json()["detail"]
    cleared = admin_client.patch(url, {"imei": ""}, content_type="application/json")
    assert cleared.status_code == 200 and cleared.json()["imei"] is None


def test_the_admin_form_has_it(vessel_a: Vessel, admin_client: Client) -> None:
    page = admin_client.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/")
    assert b'name="imei"' in page.content
    assert admin_client.get("/admin/vessels/vessel/?q=" + IMEI).status_code == 200
