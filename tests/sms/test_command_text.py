"""A shore command as one SMS with its reference (sms.command_text): every command a glider
takes by SMS reads back through the glider's own language as the same kind and parameters, and
the reference as the same uid; what cannot be said in one SMS is refused by name."""

from __future__ import annotations

import uuid
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from commands import catalog
from edge_client.contract.kinds import WAVE_GLIDER
from sms import language
from sms.command_text import (
    ALPHABET,
    COMMAND_ROOM,
    REF_MARK,
    REFERENCE_LENGTH,
    command_words,
    read_reference,
    reference,
    render,
    split_reference,
)
from sms.errors import NotSayable, SmsRouteError
from sms.gsm7 import SMS_SEPTETS, is_gsm7, septets

UID = uuid.UUID("6f1c2d3e-0000-4000-8000-00000000abcd")
SAYABLE = [
    k for k in catalog.KINDS.values() if k.sms_word is not None and WAVE_GLIDER in k.vessel_kinds
]


def read_back(text: str) -> tuple[str, dict[str, Any], uuid.UUID | None]:
    """What the glider makes of the text: its one command's kind and params, and the uid."""
    rest, uid = split_reference(text)
    items = language.parse(rest, vessel_kind=WAVE_GLIDER)
    assert len(items) == 1 and items[0].kind == language.ItemKind.COMMAND, items
    return items[0].command, dict(items[0].params), uid


# -- the field trial's commands ----------------------------------------------------------------

FIELD_TRIAL = [
    ("fhead", {"bearing": 230}, "#FHEAD 230"),
    ("hold", {}, "#HOLD"),
    ("waypoint", {"index": 1, "lat": -32.038, "lon": 115.3325}, "#WAYPOINT 1 -32.038 115.3325"),
    ("holdwp", {"index": 1}, "#HOLDWP 1"),
    ("fseq", {"target": 1, "begin": 1, "end": 4}, "#FSEQ 1 1 4"),
    ("fcourse", {"mode": "HOLD", "indices": [3, 4, 1]}, "#FCOURSE HOLD 3 4 1"),
    ("light", {"state": "on"}, "#LIGHT ON"),
    ("ir", {"state": "off"}, "#IR OFF"),
    ("rudder", {"angle": -30}, "#RUDDER -30"),
]


@pytest.mark.parametrize(("kind", "params", "words"), FIELD_TRIAL)
def test_the_field_trials_commands_go_as_the_glider_reads_them(kind, params, words):
    text = render(kind, params, UID)
    assert text == f"{words} {reference(UID)}"
    assert read_back(text) == (kind, catalog.validate(kind, params).params, UID)


def test_coordinates_are_written_exactly_not_to_the_echos_4_decimals():
    params = {"index": 7, "lat": -32.03801234567, "lon": 115.00000001}
    text = render("waypoint", params, UID)
    assert text.startswith("#WAYPOINT 7 -32.03801234567 115.00000001 ref:")
    assert read_back(text)[1] == params
    tiny = render("waypoint", {"index": 1, "lat": 1e-7, "lon": -0.0}, UID)
    assert tiny.startswith("#WAYPOINT 1 0.0000001 -0.0 ")  # never an exponent


# -- every command, every value ----------------------------------------------------------------


def _values(param: catalog.Param) -> st.SearchStrategy[Any]:
    if param.kind == "int":
        return st.integers(int(param.minimum), int(param.maximum))  # type: ignore[arg-type]
    if param.kind == "float":
        return st.floats(param.minimum, param.maximum, allow_nan=False)
    if param.kind == "choice":
        return st.sampled_from(param.choices)
    if param.kind == "indices":
        index = st.integers(int(param.minimum), int(param.maximum))  # type: ignore[arg-type]
        return st.lists(index, min_size=1, max_size=40)
    raise AssertionError(f"a glider SMS command with a {param.kind} parameter")


@st.composite
def commands(draw: st.DrawFn) -> tuple[str, dict[str, Any]]:
    spec = draw(st.sampled_from(SAYABLE))
    return spec.name, {p.name: draw(_values(p)) for p in spec.params}


@given(commands(), st.uuids())
def test_every_glider_command_reads_back_the_same_or_is_refused_as_too_long(command, uid):
    kind, params = command
    words = command_words(kind, params)
    if septets(words) > COMMAND_ROOM:
        with pytest.raises(NotSayable, match="too long for one SMS"):
            render(kind, params, uid)
        return
    text = render(kind, params, uid)
    assert septets(text) <= SMS_SEPTETS and is_gsm7(text) and "@" not in text
    assert read_back(text) == (kind, catalog.validate(kind, params).params, uid)


# Positions as charts and GPS give them (to 1e-7 degrees, about 1 cm), on every waypoint index.
coordinates = st.tuples(
    st.integers(1, 254),
    st.integers(-900_000_000, 900_000_000).map(lambda n: n / 1e7),
    st.integers(-1_800_000_000, 1_800_000_000).map(lambda n: n / 1e7),
)


@given(coordinates, st.uuids())
def test_every_real_waypoint_fits_one_sms_and_reads_back_exactly(waypoint, uid):
    index, lat, lon = waypoint
    text = render("waypoint", {"index": index, "lat": lat, "lon": lon}, uid)
    assert read_back(text) == ("waypoint", {"index": index, "lat": lat, "lon": lon}, uid)


# -- what cannot go ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kind", "params", "why"),
    [
        ("mission", {"items": [{"lat": 1, "lon": 2}]}, "mission: a Wave Glider has no SMS word"),
        ("fence", {"fences": []}, "fence: a Wave Glider has no SMS word"),
        ("move_to", {"lat": 1, "lon": 2}, "move_to: a Wave Glider has no SMS word"),
        ("fcourse", {"mode": "LOOP", "indices": list(range(1, 60))}, "fcourse: too long"),
        ("fhead", {"bearing": 400}, "fhead: bearing must be between 0 and 359"),
        ("nonsense", {}, "unknown command kind 'nonsense'"),
    ],
)
def test_a_command_that_cannot_be_said_in_one_sms_is_refused_saying_why(kind, params, why):
    with pytest.raises(NotSayable, match=why) as refused:
        render(kind, params, UID)
    assert isinstance(refused.value, SmsRouteError)


def test_the_longest_course_that_fits_goes_and_one_more_index_does_not():
    fits = ["1"]
    while len(" ".join(["#FCOURSE LOOP", *fits, "100"])) <= COMMAND_ROOM:
        fits.append("100")
    indices = [int(i) for i in fits]
    assert len(render("fcourse", {"mode": "LOOP", "indices": indices}, UID)) <= SMS_SEPTETS
    with pytest.raises(NotSayable, match="too long"):
        render("fcourse", {"mode": "LOOP", "indices": [*indices, 100]}, UID)


# -- the reference -----------------------------------------------------------------------------


@given(st.uuids())
def test_a_reference_reads_back_in_any_case(uid):
    ref = reference(uid)
    assert len(ref) == REFERENCE_LENGTH and ref.startswith(REF_MARK)
    assert read_reference(ref) == uid
    assert read_reference(ref.lower()) == read_reference(ref.upper()) == uid


@given(st.uuids(), st.integers(len(REF_MARK), REFERENCE_LENGTH - 1), st.sampled_from(ALPHABET))
def test_a_reference_with_one_character_changed_is_not_a_reference(uid, at, char):
    ref = reference(uid)
    damaged = ref[:at] + char + ref[at + 1 :]
    assert read_reference(damaged) == (uid if damaged == ref else None)


def test_a_text_without_a_valid_reference_at_its_end_is_left_whole():
    ref = reference(UID)
    assert split_reference("#FHEAD 230") == ("#FHEAD 230", None)
    assert split_reference(f"#FHEAD 230 {ref}") == ("#FHEAD 230", UID)
    assert split_reference(f"#FHEAD 230\n{ref.upper()}  ") == ("#FHEAD 230", UID)
    assert split_reference(f"{ref} #FHEAD 230") == (f"{ref} #FHEAD 230", None)  # only at the end
    assert split_reference(f"#FHEAD 230{ref}") == (f"#FHEAD 230{ref}", None)  # a word of its own
    damaged = ref[:-1] + ("A" if ref[-1] != "A" else "B")
    assert split_reference(f"#HOLD {damaged}") == (f"#HOLD {damaged}", None)
    (item,) = language.parse(f"#HOLD {damaged}", vessel_kind=WAVE_GLIDER)
    assert item.kind == language.ItemKind.ERROR and "extra: ref:" in item.error
