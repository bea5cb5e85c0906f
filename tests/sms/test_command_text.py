"""A shore command as one SMS with its signed reference (sms.command_text): every command a
glider takes by SMS reads back through the glider's own language as the same kind and
parameters, and the reference as the same uid under the vessel key's hash and no other; what
cannot be said in one SMS is refused by name."""

from __future__ import annotations

import hashlib
import hmac
import uuid
import zlib
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
    MAC_BITS,
    REF_MARK,
    REFERENCE_LENGTH,
    Reference,
    command_words,
    mac,
    read_reference,
    reference,
    render,
    same_command,
    split_reference,
    verified_uid,
)
from sms.errors import NotSayable, SmsRouteError
from sms.gsm7 import SMS_SEPTETS, is_gsm7, septets
from vessels.keys import generate_key, hash_key

UID = uuid.UUID("6f1c2d3e-0000-4000-8000-00000000abcd")
KEY = hash_key("ssk_the-gliders-shore-link-key")
OTHER_KEY = hash_key("ssk_another-vessels-key")
SAYABLE = [
    k for k in catalog.KINDS.values() if k.sms_word is not None and WAVE_GLIDER in k.vessel_kinds
]


def read_back(text: str) -> tuple[str, dict[str, Any], uuid.UUID | None]:
    """What the glider makes of the text: its one command's kind and params, and the uid."""
    rest, token = split_reference(text)
    uid = verified_uid(rest, token, KEY) if token else None
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
    text = render(kind, params, UID, KEY)
    assert text == f"{words} {reference(UID, words, KEY)}"
    assert read_back(text) == (kind, catalog.validate(kind, params).params, UID)


def test_coordinates_are_written_exactly_not_to_the_echos_4_decimals():
    params = {"index": 7, "lat": -32.03801234567, "lon": 115.00000001}
    text = render("waypoint", params, UID, KEY)
    assert text.startswith("#WAYPOINT 7 -32.03801234567 115.00000001 ref:")
    assert read_back(text)[1] == params
    tiny = render("waypoint", {"index": 1, "lat": 1e-7, "lon": -0.0}, UID, KEY)
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
            render(kind, params, uid, KEY)
        return
    text = render(kind, params, uid, KEY)
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
    text = render("waypoint", {"index": index, "lat": lat, "lon": lon}, uid, KEY)
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
        render(kind, params, UID, KEY)
    assert isinstance(refused.value, SmsRouteError)


def test_the_longest_course_that_fits_goes_and_one_more_index_does_not():
    fits = ["1"]
    while len(" ".join(["#FCOURSE LOOP", *fits, "100"])) <= COMMAND_ROOM:
        fits.append("100")
    indices = [int(i) for i in fits]
    assert len(render("fcourse", {"mode": "LOOP", "indices": indices}, UID, KEY)) <= SMS_SEPTETS
    with pytest.raises(NotSayable, match="too long"):
        render("fcourse", {"mode": "LOOP", "indices": [*indices, 100]}, UID, KEY)


# -- the reference -----------------------------------------------------------------------------


WORDS = "#FHEAD 230"


def test_the_mac_is_hmac_sha256_keyed_with_the_key_hash_over_the_uid_and_the_words():
    """Pinned from the definition, independently of the module: shore and glider must agree."""
    digest = hmac.new(
        bytes.fromhex(KEY),
        b"shoreside sms command reference v1\n" + UID.bytes + WORDS.encode(),
        hashlib.sha256,
    ).digest()
    assert mac(UID, WORDS, KEY) == int.from_bytes(digest[: MAC_BITS // 8], "big")
    assert read_reference(reference(UID, WORDS, KEY)) == Reference(UID, mac(UID, WORDS, KEY))
    with pytest.raises(ValueError, match="64 hex digits"):
        mac(UID, WORDS, "abcd")


@given(st.uuids(), st.text(min_size=1, max_size=40))
def test_a_reference_verifies_in_any_case_under_its_key_only(uid, key):
    key_hash = hash_key(key)
    ref = reference(uid, WORDS, key_hash)
    assert len(ref) == REFERENCE_LENGTH and ref.startswith(REF_MARK)
    assert verified_uid(WORDS, ref, key_hash) == uid
    assert verified_uid(WORDS, ref.lower(), key_hash) == uid
    assert verified_uid(WORDS, ref, hash_key(key + "x")) is None


def test_a_reference_does_not_verify_over_other_words_or_without_a_key():
    ref = reference(UID, "#LIGHT ON", KEY)
    assert verified_uid("#LIGHT ON", ref, KEY) == UID
    assert verified_uid("#light  ON\n", ref, KEY) is None  # the case is the words'
    assert verified_uid(" #LIGHT\tON ", ref, KEY) == UID  # white space is not
    assert verified_uid("#LIGHT OFF", ref, KEY) is None  # the command changed under it
    assert verified_uid("#LIGHT ON", ref, OTHER_KEY) is None  # another key made it
    assert verified_uid("#LIGHT ON", reference(UID, "#LIGHT ON", OTHER_KEY), KEY) is None
    assert verified_uid("#LIGHT ON", ref, None) is None  # nothing to check it with
    assert verified_uid("#LIGHT ON", ref, "") is None


def test_an_old_crc_only_reference_is_not_a_reference():
    """The 28-character form (the uid and a CRC anyone can compute) reads as nothing."""
    value = (UID.int << 12) | (zlib.crc32(UID.bytes) & 0xFFF)
    old = REF_MARK + "".join(ALPHABET[(value >> (5 * i)) & 31] for i in reversed(range(28)))
    assert read_reference(old) is None and verified_uid(WORDS, old, KEY) is None
    assert split_reference(f"{WORDS} {old}") == (WORDS, old)  # taken off, then refused


@given(st.uuids(), st.integers(len(REF_MARK), REFERENCE_LENGTH - 1), st.sampled_from(ALPHABET))
def test_a_reference_with_one_character_changed_does_not_verify(uid, at, char):
    ref = reference(uid, WORDS, KEY)
    damaged = ref[:at] + char + ref[at + 1 :]
    assert verified_uid(WORDS, damaged, KEY) == (uid if damaged == ref else None)


def test_the_ref_word_at_the_end_of_a_text_is_taken_off_whatever_it_holds():
    ref = reference(UID, WORDS, KEY)
    assert split_reference("#FHEAD 230") == ("#FHEAD 230", None)
    assert split_reference(f"#FHEAD 230 {ref}") == ("#FHEAD 230", ref)
    assert split_reference(f"#FHEAD 230\n{ref.upper()}  ") == ("#FHEAD 230", ref.upper())
    assert split_reference(f"{ref} #FHEAD 230") == (f"{ref} #FHEAD 230", None)  # only at the end
    assert split_reference(f"#FHEAD 230{ref}") == (f"#FHEAD 230{ref}", None)  # a word of its own
    assert split_reference("#HOLD REF:1234") == ("#HOLD", "REF:1234")  # ours or not: checked next
    (item,) = language.parse(f"#HOLD {ref}", vessel_kind=WAVE_GLIDER)
    assert item.kind == language.ItemKind.ERROR and "extra: ref:" in item.error


def test_every_reference_is_plain_gsm7_and_a_fresh_key_signs_too():
    key_hash = hash_key(generate_key())
    ref = reference(uuid.uuid4(), WORDS, key_hash)
    assert is_gsm7(ref) and "@" not in ref and septets(ref) == REFERENCE_LENGTH


# -- the same command? -------------------------------------------------------------------------


def test_the_same_command_is_told_by_kind_and_validated_params():
    assert same_command("fhead", {"bearing": 230}, "fhead", {"bearing": 230.0})
    assert same_command("light", {"state": "on"}, "light", {"state": "ON"})
    assert same_command("fcourse", {"mode": "HOLD", "indices": (3, 4)},
                        "fcourse", {"mode": "HOLD", "indices": [3, 4]})  # fmt: skip
    assert not same_command("light", {"state": "on"}, "light", {"state": "off"})
    assert not same_command("fhead", {"bearing": 230}, "rudder", {"angle": 230})
    assert not same_command("fhead", {"bearing": 230}, "fhead", {"bearing": 231})
    assert same_command("nonsense", {"a": 1}, "nonsense", {"a": 1})  # as given
    assert not same_command("nonsense", {"a": 1}, "nonsense", {"a": 2})
