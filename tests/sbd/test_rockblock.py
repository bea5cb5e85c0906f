"""RockBLOCK's wire formats, pure (sbd/rockblock.py): the delivery's fields, the MT answer."""

from __future__ import annotations

import datetime as dt

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sbd.errors import DeliveryError, MtError
from sbd.rockblock import FIELDS, credits, parse_delivery, parse_mt_answer

GOOD = {
    "imei": "300434063839690",
    "momsn": "12",
    "transmit_time": "21-10-31 10:41:50",
    "iridium_latitude": "50.2563",
    "iridium_longitude": "-5.0981",
    "iridium_cep": "4.0",
    "data": "48656c6c6f",
}


def test_a_delivery_as_the_provider_sends_it() -> None:
    d = parse_delivery(GOOD)
    assert (d.imei, d.momsn, d.data) == ("300434063839690", 12, b"Hello")
    assert d.transmit_time == dt.datetime(2021, 10, 31, 10, 41, 50, tzinfo=dt.UTC)
    assert (d.lat, d.lon, d.cep_km) == (50.2563, -5.0981, 4.0)
    assert parse_delivery({**GOOD, "data": ""}).data == b""


@pytest.mark.parametrize("field", FIELDS)
def test_a_missing_field_is_named(field: str) -> None:
    form = {k: v for k, v in GOOD.items() if k != field}
    with pytest.raises(DeliveryError, match=f"^{field}: missing"):
        parse_delivery(form)


def test_a_payload_longer_than_a_modem_sends_is_refused() -> None:
    parse_delivery({**GOOD, "data": "00" * 340})
    with pytest.raises(DeliveryError, match="over 340 bytes"):
        parse_delivery({**GOOD, "data": "00" * 341})


text = st.text(max_size=30) | st.sampled_from(list(GOOD.values()))


@given(st.dictionaries(st.sampled_from([*FIELDS, "JWT", "x"]), text))
def test_any_form_is_a_delivery_or_a_delivery_error(form: dict[str, str]) -> None:
    try:
        parse_delivery(form)
    except DeliveryError as exc:
        assert exc.field in FIELDS


def test_the_mt_answers() -> None:
    assert parse_mt_answer("OK,12345678\n") == "12345678"
    with pytest.raises(MtError, match="11 No RockBLOCK") as refused:
        parse_mt_answer("FAILED,11,No RockBLOCK with this IMEI found on your account")
    assert refused.value.permanent
    with pytest.raises(MtError) as credit:
        parse_mt_answer("FAILED,13,Insufficient credit")
    assert not credit.value.permanent
    for odd in ["", "OK", "OK,", "<html>", "FAILED"]:
        with pytest.raises(MtError) as exc:
            parse_mt_answer(odd)
        assert not exc.value.permanent


def test_credits_are_50_bytes_each_one_at_least() -> None:
    assert [credits(n) for n in (0, 1, 50, 51, 100, 340)] == [1, 1, 1, 2, 2, 7]
