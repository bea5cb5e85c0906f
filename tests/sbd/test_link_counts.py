"""SBD traffic on the vessel's link counts (links.LinkDay), through the real webhook and the
real MT sender (a local HTTP server standing in for RockBLOCK)."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from django.test import Client
from django.utils import timezone

from commands.services import command_enqueue
from edge_client.contract import compact
from links.models import LinkDay
from sbd.rockblock import credits
from sbd.services import sbd_send_command, sbd_send_queued
from tests.sbd.conftest import URL, MtEndpoint, Provider
from tests.sbd.test_webhook import FIXES
from vessels.models import Vessel

pytestmark = pytest.mark.django_db


def sbd_row(vessel: Vessel) -> LinkDay:
    return LinkDay.objects.get(vessel=vessel, transport="sbd")


@pytest.mark.parametrize(("size", "paid"), [(0, 1), (1, 1), (50, 1), (51, 2), (340, 7)])
def test_credits_are_50_bytes_started_at_least_one(size: int, paid: int) -> None:
    assert credits(size) == paid


def test_a_delivery_is_counted_once_with_its_bytes_credits_and_fixes(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    payload = compact.encode(FIXES * 1)
    delivery = provider.delivery(payload)
    assert webhook.post(URL, delivery).json()["status"] == "stored"
    assert webhook.post(URL, delivery).json()["status"] == "duplicate"  # the provider's retry
    webhook.post(URL, provider.delivery(b""))  # a mailbox check: the Iridium position, 1 credit
    row = sbd_row(sbd_vessel)
    assert (row.messages_in, row.bytes_in) == (2, len(payload))
    assert row.credits == credits(len(payload)) + 1
    assert row.fixes_in == 3 and row.messages_out == 0
    assert row.day == timezone.now().date() and row.last_contact_at is not None


def test_a_refused_delivery_counts_nothing(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    response = webhook.post(URL, provider.fields(compact.encode(FIXES)))  # unsigned
    assert response.status_code == 403
    assert not LinkDay.objects.exists()


@pytest.fixture
def mt(settings: Any, mt_endpoint: MtEndpoint) -> MtEndpoint:
    settings.SBD_ROCKBLOCK_MT_URL = mt_endpoint.url
    settings.SBD_ROCKBLOCK_USERNAME = "shore@example.org"
    settings.SBD_ROCKBLOCK_PASSWORD = "s3cret"
    settings.SBD_MT_MAX_ATTEMPTS = 3
    settings.MOVE_TO_MAX_M = 0
    return mt_endpoint


def test_a_command_out_is_counted_when_the_provider_takes_it(
    mt: MtEndpoint, sbd_vessel: Vessel
) -> None:
    mt.answers = [(500, "busy")]
    command = command_enqueue(vessel=sbd_vessel, kind="move_to", params={"lat": -32, "lon": 115})
    message = sbd_send_command(command)
    assert message.status == "queued"
    assert not LinkDay.objects.exists()  # a try that failed costs nothing
    assert sbd_send_queued(now=timezone.now() + dt.timedelta(seconds=31)) == 1
    row = sbd_row(sbd_vessel)
    assert (row.messages_out, row.bytes_out, row.credits) == (1, message.bytes, 1)
    assert row.last_contact_at is None  # sending to it is not hearing from it
