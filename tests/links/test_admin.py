"""The vessel page's Links block: per transport, last contact, today's and the week's
messages / bytes / credits, and the bytes each fix cost."""

from __future__ import annotations

import datetime as dt
import re

import pytest
import time_machine
from django.test import Client

from links.display import fmt_age, links_html
from links.services import link_count
from vessels.models import Vessel

pytestmark = pytest.mark.django_db

NOW = dt.datetime(2026, 11, 28, 12, 0, tzinfo=dt.UTC)


def cells(html: str, transport: str) -> list[str]:
    row = re.search(rf'<tr class="link-{transport}">(.*?)</tr>', html, re.S)
    assert row, html
    return re.findall(r"<td[^>]*>(.*?)</td>", row.group(1))


def test_the_block_shows_each_transport(vessel_a: Vessel) -> None:
    yesterday = NOW - dt.timedelta(days=1)
    link_count(vessel_id=vessel_a.pk, transport="sbd", at=NOW - dt.timedelta(minutes=5),
               contact=True, messages_in=1, bytes_in=240, credits=5, fixes_in=60)  # fmt: skip
    link_count(vessel_id=vessel_a.pk, transport="sbd", at=yesterday, contact=True,
               messages_in=2, messages_out=1, bytes_in=100, bytes_out=27, credits=3,
               fixes_in=20)  # fmt: skip
    link_count(
        vessel_id=vessel_a.pk,
        transport="sbd",
        at=NOW - dt.timedelta(days=8),
        messages_in=50,
        bytes_in=5000,
        credits=100,
    )  # fmt: skip  (not in the week)
    link_count(vessel_id=vessel_a.pk, transport="http", at=NOW, contact=True, messages_in=1,
               messages_out=1, bytes_in=12_345, bytes_out=300, fixes_in=1)  # fmt: skip
    html = links_html(vessel_a.pk, now=NOW)
    assert cells(html, "sbd") == [
        "Iridium SBD", "5 min ago",
        "1 in / 0 out", "240 B in / 0 B out", "5",
        "3 in / 1 out", "340 B in / 27 B out", "8",
        "4.2 B (80 fixes)",
    ]  # fmt: skip
    assert cells(html, "http")[:3] == ["HTTP", "0 s ago", "1 in / 1 out"]
    assert cells(html, "http")[-1] == "12345 B (1 fix)"
    assert cells(html, "sms") == ["SMS", "never", *["0 in / 0 out", "0 B in / 0 B out", "0"] * 2,
                                  "–"]  # fmt: skip


def test_ages() -> None:
    assert fmt_age(NOW - dt.timedelta(seconds=59), NOW) == "59 s ago"
    assert fmt_age(NOW - dt.timedelta(hours=3, minutes=5), NOW) == "3 h ago"
    assert fmt_age(NOW - dt.timedelta(days=2), NOW) == "2 d ago"


def test_the_vessel_admin_page_renders_the_block(admin_ui: Client, vessel_a: Vessel) -> None:
    with time_machine.travel(NOW, tick=False):
        link_count(vessel_id=vessel_a.pk, transport="sms", at=NOW, contact=True,
                   messages_in=1, bytes_in=9, credits=1)  # fmt: skip
        page = admin_ui.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/").content.decode()
    assert '<table class="links">' in page and "bytes per fix" in page
    assert cells(page, "sms")[:3] == ["SMS", "0 s ago", "1 in / 0 out"]
    # The budgets are edited on the same page.
    for name in ("sbd_daily_credit_budget", "sms_daily_budget", "http_daily_budget_kb"):
        assert f'name="{name}"' in page


def test_a_budget_saved_on_the_admin_page(admin_ui: Client, vessel_a: Vessel) -> None:
    form = {"name": vessel_a.name, "kind": "mavlink", "active": "on", "telemetry_period_s": 10,
            "cruise_speed_mps": 1.5, "notes": "", "compact_channels": "[]",
            "keys-TOTAL_FORMS": 0, "keys-INITIAL_FORMS": 0,
            "sbd_daily_credit_budget": 40, "sms_daily_budget": "",
            "http_daily_budget_kb": 500}  # fmt: skip
    response = admin_ui.post(f"/admin/vessels/vessel/{vessel_a.pk}/change/", form)
    assert response.status_code == 302, response.context["adminform"].form.errors
    vessel_a.refresh_from_db()
    assert (vessel_a.sbd_daily_credit_budget, vessel_a.sms_daily_budget) == (40, None)
    assert vessel_a.http_daily_budget_kb == 500
