"""The GSM 7-bit alphabet: lengths, checks and the text-mode codec (sms/gsm7.py)."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from sms import gsm7

GSM_TEXT = st.text(alphabet=st.sampled_from([*gsm7.BASIC.replace("\x1b", ""), *gsm7.EXTENSION]))


def test_the_basic_alphabet_has_128_code_points_in_the_standards_places() -> None:
    assert len(gsm7.BASIC) == 128
    assert gsm7.encode("@£$_ΔÉ¤¡§¿à") == bytes(
        [0x00, 0x01, 0x02, 0x11, 0x10, 0x1F, 0x24, 0x40, 0x5F, 0x60, 0x7F]
    )


def test_extension_characters_take_two_septets() -> None:
    assert gsm7.septets("#FHEAD 230 OK") == 13
    assert gsm7.septets("[1]€") == 7
    assert gsm7.encode("€") == b"\x1b\x65"


def test_characters_outside_the_alphabet_are_not_gsm7_and_are_spelled_plainly() -> None:
    assert not gsm7.is_gsm7("“hold” – ok")
    assert gsm7.to_gsm7("“hold” – ok") == '"hold" - ok'
    assert gsm7.to_gsm7("Łódź 中 🚤") == "?odz ? ?"
    assert gsm7.is_gsm7(gsm7.to_gsm7("ú naïve ﬁx"))


@given(GSM_TEXT)
def test_encode_then_decode_gives_the_text_back(text: str) -> None:
    assert gsm7.decode(gsm7.encode(text)) == text
    assert len(gsm7.encode(text)) == gsm7.septets(text)


@given(st.text())
def test_any_text_becomes_gsm7(text: str) -> None:
    assert gsm7.is_gsm7(gsm7.to_gsm7(text))


@given(st.binary())
def test_any_bytes_decode_to_text(data: bytes) -> None:
    assert isinstance(gsm7.decode(data), str)
