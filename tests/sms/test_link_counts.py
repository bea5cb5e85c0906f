"""The glider's SMS log reaching the shore is counted on its SMS link (links.LinkDay): only
entries newly accepted, by direction, with the bytes the text took on the air and its
segments as credits. Through the real boat API upload."""

from __future__ import annotations

import datetime as dt

import pytest
from hypothesis import given
from hypothesis import strategies as st

from links.models import LinkDay
from sms.gsm7 import on_air
from tests.sms.test_boat_api import AT, SMS, entry, glider_boat  # noqa: F401 (fixture)
from vessels.models import Vessel


@pytest.mark.parametrize(
    ("text", "nbytes", "segments"),
    [
        ("", 0, 1),
        ("#FHEAD 230", 9, 1),  # 10 septets packed: 70 bits in 9 bytes
        ("x" * 160, 140, 1),
        ("x" * 161, 141, 2),  # 153 septets a segment once it is long
        ("x" * 306, 268, 2),
        ("x" * 307, 269, 3),
        ("€" * 80, 140, 1),  # an extension character takes two septets
        ("Ünïcödé ✓", 18, 1),  # ✓ is not GSM-7: the whole text goes in UCS-2
        ("✓" * 71, 142, 2),  # 67 units a segment in UCS-2
        ("🙂", 4, 1),  # a surrogate pair: two UTF-16 units
    ],
)
def test_the_bytes_and_segments_on_the_air(text: str, nbytes: int, segments: int) -> None:
    assert on_air(text) == (nbytes, segments)


@given(st.text(max_size=700))
def test_any_text_costs_at_least_one_segment_and_at_most_its_ucs2_bytes(text: str) -> None:
    nbytes, segments = on_air(text)
    assert segments >= 1 and 0 <= nbytes <= len(text.encode("utf-16-le"))
    assert nbytes <= segments * 140  # a segment carries at most 140 bytes of user data


@pytest.mark.django_db
def test_an_uploaded_log_counts_each_new_sms_once_by_direction(
    glider: Vessel,
    glider_boat,  # noqa: F811
) -> None:
    later = AT + dt.timedelta(minutes=3)
    batch = [
        entry("m1", text="#FHEAD 230"),
        entry("m2", text="x" * 200, received_at=later.isoformat()),
        entry("r1", direction="out", text="OK heading 230", status="sent", outcome="",
              authorised=False, sent_at=later.isoformat(), received_at=None),
        entry("r2", direction="out", text="never left", status="failed", outcome="",
              authorised=False, received_at=None),
    ]  # fmt: skip
    first = glider_boat.post(SMS, batch, format="json")
    assert first.status_code == 200, first.content
    assert first.json()["accepted"] == 4
    again = glider_boat.post(SMS, batch[:2], format="json").json()  # re-sent: duplicates
    assert again["duplicates"] == 2
    row = LinkDay.objects.get(vessel=glider, transport="sms")
    assert row.day == AT.date()
    assert (row.messages_in, row.bytes_in) == (2, 9 + 175)
    assert (row.messages_out, row.bytes_out) == (1, on_air("OK heading 230")[0])
    assert row.credits == 1 + 2 + 1  # the 200-character SMS went in two segments
    assert row.last_contact_at == later  # the newest SMS heard from it, not the reply
