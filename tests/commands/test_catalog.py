"""The command catalog (docs/operating.md): kinds, vessel kinds, ranges, types, SMS text form."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from commands import catalog
from commands.catalog import MAVLINK, WAVE_GLIDER, CatalogError, parse_text, to_text, validate

# One valid parameter set per kind, and the vessel kinds each kind allows.
VALID: dict[str, tuple[dict[str, Any], tuple[str, ...]]] = {
    "move_to": ({"lat": -31.9505, "lon": 115.8605}, (MAVLINK,)),
    "hold": ({}, (MAVLINK, WAVE_GLIDER)),
    "resume": ({}, (MAVLINK,)),
    "return_home": ({}, (MAVLINK,)),
    "set_mode": ({"mode": "GUIDED"}, (MAVLINK,)),
    "arm": ({}, (MAVLINK,)),
    "disarm": ({}, (MAVLINK,)),
    "mission": ({"items": [{"lat": -32.0, "lon": 115.7}], "loop": True}, (MAVLINK,)),
    "fence": (
        {
            "fences": [
                {
                    "name": "Bay",
                    "inclusion": True,
                    "circle": {"lat": -32, "lon": 115.7, "radius_m": 500},
                }
            ]
        },
        (MAVLINK,),
    ),
    "fhead": ({"bearing": 230}, (WAVE_GLIDER,)),
    "light": ({"state": "on"}, (WAVE_GLIDER,)),
    "ir": ({"state": "off"}, (WAVE_GLIDER,)),
    "waypoint": ({"index": 1, "lat": -32.038, "lon": 115.3325}, (WAVE_GLIDER,)),
    "holdwp": ({"index": 1}, (WAVE_GLIDER,)),
    "fseq": ({"target": 1, "begin": 1, "end": 4}, (WAVE_GLIDER,)),
    "rudder": ({"angle": -30}, (WAVE_GLIDER,)),
    "fcourse": ({"mode": "HOLD", "indices": [3, 4, 1]}, (WAVE_GLIDER,)),
}

NAVIGATION = {
    "move_to",
    "hold",
    "resume",
    "return_home",
    "set_mode",
    "mission",
    "fhead",
    "holdwp",
    "fseq",
    "rudder",
    "fcourse",
}


def test_it_covers_every_kind_in_the_design_table() -> None:
    assert set(catalog.KINDS) == set(VALID)


@pytest.mark.parametrize("kind", sorted(VALID))
@pytest.mark.parametrize("vessel_kind", [MAVLINK, WAVE_GLIDER])
def test_it_allows_each_kind_only_on_its_vessel_kinds(kind: str, vessel_kind: str) -> None:
    params, allowed = VALID[kind]
    if vessel_kind in allowed:
        valid = validate(kind, params, vessel_kind=vessel_kind)
        assert valid.kind == kind
        assert valid.navigation is (kind in NAVIGATION)
    else:
        with pytest.raises(CatalogError) as err:
            validate(kind, params, vessel_kind=vessel_kind)
        assert err.value.field == "kind"
        assert f"not available for {vessel_kind}" in err.value.message


def test_it_lists_the_kinds_for_a_vessel_kind() -> None:
    glider = {k.name for k in catalog.kinds_for(WAVE_GLIDER)}
    assert glider == {k for k, (_, allowed) in VALID.items() if WAVE_GLIDER in allowed}
    assert "hold" in {k.name for k in catalog.kinds_for(MAVLINK)}


def test_it_refuses_an_unknown_kind_naming_the_known_ones() -> None:
    with pytest.raises(CatalogError) as err:
        validate("self_destruct", {})
    assert err.value.field == "kind"
    assert "unknown command kind 'self_destruct'" in err.value.message
    assert "move_to" in err.value.message


@pytest.mark.parametrize("kind", [None, 3, ["move_to"], {"a": 1}])
def test_it_refuses_a_kind_that_is_not_a_string(kind: Any) -> None:
    with pytest.raises(CatalogError):
        validate(kind, {})


def test_it_refuses_an_unknown_parameter_naming_it() -> None:
    with pytest.raises(CatalogError) as err:
        validate("move_to", {"lat": 1, "lon": 2, "alt": 3}, vessel_kind=MAVLINK)
    assert err.value.field == "alt"
    assert "unknown parameter 'alt'" in err.value.message
    assert err.value.as_dict() == {"alt": [err.value.message]}


def test_it_refuses_parameters_for_a_kind_that_takes_none() -> None:
    with pytest.raises(CatalogError, match=r"allowed: none"):
        validate("arm", {"force": True}, vessel_kind=MAVLINK)


@pytest.mark.parametrize("params", [[1, 2], "lat=1", 5, True])
def test_it_refuses_params_that_are_not_an_object(params: Any) -> None:
    with pytest.raises(CatalogError) as err:
        validate("move_to", params, vessel_kind=MAVLINK)
    assert err.value.field == "params"


def test_it_treats_missing_params_as_empty() -> None:
    assert validate("hold", None, vessel_kind=WAVE_GLIDER).params == {}


def test_it_names_a_missing_required_parameter() -> None:
    with pytest.raises(CatalogError) as err:
        validate("move_to", {"lat": 1}, vessel_kind=MAVLINK)
    assert err.value.field == "lon"
    assert "lon is required" in err.value.message


@pytest.mark.parametrize(
    ("kind", "params", "field"),
    [
        ("move_to", {"lat": 90.0001, "lon": 0}, "lat"),
        ("move_to", {"lat": -90.5, "lon": 0}, "lat"),
        ("move_to", {"lat": 0, "lon": 180.01}, "lon"),
        ("move_to", {"lat": 0, "lon": -181}, "lon"),
        ("fhead", {"bearing": 360}, "bearing"),
        ("fhead", {"bearing": -1}, "bearing"),
        ("rudder", {"angle": 31}, "angle"),
        ("rudder", {"angle": -31}, "angle"),
        ("waypoint", {"index": 0, "lat": 0, "lon": 0}, "index"),
        ("waypoint", {"index": 255, "lat": 0, "lon": 0}, "index"),
        ("holdwp", {"index": 255}, "index"),
        ("fseq", {"target": 1, "begin": 0, "end": 4}, "begin"),
        ("fcourse", {"mode": "LOOP", "indices": [1, 255]}, "indices"),
        ("mission", {"mission_id": 0, "items": [{"lat": 0, "lon": 0}]}, "mission_id"),
    ],
)
def test_it_refuses_values_out_of_range(kind: str, params: dict[str, Any], field: str) -> None:
    with pytest.raises(CatalogError) as err:
        validate(kind, params)
    assert err.value.field == field
    assert "must be between" in err.value.message


@pytest.mark.parametrize(
    ("kind", "params"),
    [
        ("move_to", {"lat": 90, "lon": 180}),
        ("move_to", {"lat": -90, "lon": -180}),
        ("fhead", {"bearing": 0}),
        ("fhead", {"bearing": 359}),
        ("rudder", {"angle": 30}),
        ("waypoint", {"index": 254, "lat": 0, "lon": 0}),
        ("holdwp", {"index": 1}),
    ],
)
def test_it_accepts_the_ends_of_each_range(kind: str, params: dict[str, Any]) -> None:
    assert validate(kind, params).params == params


@pytest.mark.parametrize(
    ("kind", "params", "field"),
    [
        ("move_to", {"lat": True, "lon": 0}, "lat"),
        ("move_to", {"lat": "-31.9", "lon": 0}, "lat"),
        ("move_to", {"lat": float("nan"), "lon": 0}, "lat"),
        ("move_to", {"lat": 0, "lon": float("inf")}, "lon"),
        ("move_to", {"lat": 10**400, "lon": 0}, "lat"),
        ("fhead", {"bearing": True}, "bearing"),
        ("fhead", {"bearing": 12.5}, "bearing"),
        ("fhead", {"bearing": "230"}, "bearing"),
        ("holdwp", {"index": False}, "index"),
        ("light", {"state": True}, "state"),
        ("light", {"state": "dim"}, "state"),
        ("set_mode", {"mode": "WARP"}, "mode"),
        ("set_mode", {"mode": 15}, "mode"),
        ("mission", {"items": [], "loop": False}, "items"),
        ("mission", {"items": [{"lat": 0, "lon": 0}], "loop": "yes"}, "loop"),
        ("mission", {"items": [{"lat": 0, "lon": 0}], "loop": 1}, "loop"),
        ("mission", {"items": ["a"]}, "items"),
        ("fcourse", {"mode": "LOOP", "indices": []}, "indices"),
        ("fcourse", {"mode": "LOOP", "indices": [1, True]}, "indices"),
        ("fcourse", {"mode": "LOOP", "indices": "1 2"}, "indices"),
    ],
)
def test_it_refuses_wrong_types_including_bools(
    kind: str, params: dict[str, Any], field: str
) -> None:
    with pytest.raises(CatalogError) as err:
        validate(kind, params)
    assert err.value.field == field
    assert field in err.value.message


def test_it_says_how_large_a_huge_integer_is_without_overflowing() -> None:
    with pytest.raises(CatalogError) as err:
        validate("fhead", {"bearing": 10**400})
    assert "bearing must be between 0 and 359" in err.value.message
    with pytest.raises(CatalogError) as err:
        validate("fhead", {"bearing": 1e300})
    assert len(err.value.message) < 100


def test_it_normalises_values() -> None:
    assert validate("fhead", {"bearing": 230.0}).params == {"bearing": 230}
    assert validate("light", {"state": " ON "}).params == {"state": "on"}
    assert validate("set_mode", {"mode": "guided"}).params == {"mode": "GUIDED"}
    assert validate("move_to", {"lat": -32, "lon": 115}).params == {"lat": -32.0, "lon": 115.0}


def test_it_fills_mission_defaults_and_checks_each_waypoint() -> None:
    valid = validate("mission", {"items": [{"lat": -32, "lon": 115.7, "hold_s": 10}]})
    assert valid.params == {
        "mission_id": None,
        "loop": False,
        "end": "stop",
        "items": [
            {"lat": -32.0, "lon": 115.7, "hold_s": 10.0, "radius_m": None, "speed_mps": None}
        ],
    }
    with pytest.raises(CatalogError) as err:
        validate("mission", {"items": [{"lat": 0, "lon": 0}, {"lat": 91, "lon": 0}]})
    assert err.value.field == "items"
    assert err.value.message.startswith("items[1]: lat must be between")
    with pytest.raises(CatalogError, match=r"items\[0\]: unknown parameter 'alt'"):
        validate("mission", {"items": [{"lat": 0, "lon": 0, "alt": 5}]})


def test_it_caps_the_number_of_mission_waypoints() -> None:
    items = [{"lat": 0, "lon": 0}] * (catalog.MISSION_MAX_ITEMS + 1)
    with pytest.raises(CatalogError, match=r"at most 500"):
        validate("mission", {"items": items})


# --- the SMS text form (docs/sms.md: the language and the 2018 field trial) ---


@pytest.mark.parametrize(
    ("text", "kind", "params"),
    [
        ("#FHEAD 230", "fhead", {"bearing": 230}),
        ("#HOLD", "hold", {}),
        (
            "#WAYPOINT 1 -32.0380 115.3325",
            "waypoint",
            {"index": 1, "lat": -32.038, "lon": 115.3325},
        ),
        ("#HOLDWP 1", "holdwp", {"index": 1}),
        (
            "#WAYPOINT 4 -32.0345 115.3326",
            "waypoint",
            {"index": 4, "lat": -32.0345, "lon": 115.3326},
        ),
        ("#FSEQ 1 1 4", "fseq", {"target": 1, "begin": 1, "end": 4}),
        ("#FCOURSE HOLD 3 4 1", "fcourse", {"mode": "HOLD", "indices": [3, 4, 1]}),
        ("#LIGHT ON", "light", {"state": "on"}),
        ("#IR off", "ir", {"state": "off"}),
        ("#RUDDER -30", "rudder", {"angle": -30}),
        ("  #fhead   0 ", "fhead", {"bearing": 0}),
    ],
)
def test_it_parses_the_field_trial_commands(text: str, kind: str, params: dict[str, Any]) -> None:
    valid = parse_text(text)
    assert (valid.kind, valid.params) == (kind, params)


def test_it_keeps_the_holdwp_index_rather_than_reading_it_as_hold() -> None:
    # Field trial, 12:09 (docs/sms.md): "#HOLDWP 1" was misinterpreted as #HOLD on the glider.
    valid = parse_text("#HOLDWP 1")
    assert valid.kind == "holdwp"
    assert valid.params == {"index": 1}
    assert to_text(valid.kind, valid.params) == "#HOLDWP 1"


def test_it_keeps_all_three_fseq_indices() -> None:
    # Field trial, 12:28 (docs/sms.md): "#FSEQ 1 1 4" was echoed as "#FSEQ 1 1", no end index.
    valid = parse_text("#FSEQ 1 1 4")
    assert to_text(valid.kind, valid.params) == "#FSEQ 1 1 4"


def test_it_refuses_a_short_fseq_rather_than_sending_it() -> None:
    with pytest.raises(CatalogError) as err:
        parse_text("#FSEQ 1 1")
    assert err.value.field == "end"
    assert "#FSEQ needs end" in err.value.message


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("FHEAD 230", "starts with #"),
        ("", "starts with #"),
        ("#FLY 3", "unknown command #FLY"),
        ("#FHEAD", "#FHEAD needs bearing"),
        ("#FHEAD 230 240", "extra: 240"),
        ("#FHEAD east", "bearing must be a number (got 'east')"),
        ("#FHEAD 360", "bearing must be between 0 and 359"),
        ("#HOLDWP 1.5", "index must be a number"),
        ("#WAYPOINT 1 nan 115", "lat must be a number"),
        ("#LIGHT DIM", "state must be one of on, off"),
        ("#FCOURSE LOOP", "indices must be a non-empty list"),
        ("#FCOURSE 3 4", "mode must be one of LOOP, HOLD"),
        ("#HOLD now", "extra: now"),
    ],
)
def test_it_explains_what_is_wrong_with_a_text_command(text: str, expected: str) -> None:
    with pytest.raises(CatalogError) as err:
        parse_text(text)
    assert expected in err.value.message


def test_it_refuses_text_commands_for_the_wrong_vessel_kind() -> None:
    with pytest.raises(CatalogError, match="not available for mavlink"):
        parse_text("#FHEAD 230", vessel_kind=MAVLINK)
    assert parse_text("#HOLD", vessel_kind=MAVLINK).kind == "hold"


@pytest.mark.parametrize("kind", sorted(k for k, spec in catalog.KINDS.items() if spec.sms_word))
def test_it_round_trips_every_text_form(kind: str) -> None:
    params, _ = VALID[kind]
    valid = validate(kind, params)
    text = to_text(valid.kind, valid.params)
    again = parse_text(text)
    assert (again.kind, again.params) == (valid.kind, valid.params)
    assert to_text(again.kind, again.params) == text


def test_it_formats_coordinates_with_four_decimals_as_in_the_thesis() -> None:
    assert to_text("waypoint", {"index": 1, "lat": -32.038, "lon": 115.3325}) == (
        "#WAYPOINT 1 -32.0380 115.3325"
    )


def test_it_has_no_text_form_for_mavlink_only_kinds() -> None:
    with pytest.raises(CatalogError, match="move_to has no text form"):
        to_text("move_to", {"lat": 0, "lon": 0})


# --- property-based: nothing but CatalogError, whatever arrives ---

json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.integers(min_value=10**300, max_value=10**400)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=10),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4)
    ),
    max_leaves=12,
)


def _params_for(kind: str) -> st.SearchStrategy[Any]:
    names = [p.name for p in catalog.KINDS[kind].params] + ["extra"]
    return st.dictionaries(st.sampled_from(names), json_values, max_size=4) | json_values


@given(
    kind=st.sampled_from(sorted(catalog.KINDS)) | st.text(max_size=10),
    data=st.data(),
    vessel_kind=st.sampled_from([MAVLINK, WAVE_GLIDER, None]),
)
@example(kind="move_to", data=None, vessel_kind=None)
def test_validate_raises_only_catalog_errors(kind: str, data: Any, vessel_kind: str | None) -> None:
    params = (
        {"lat": 10**400, "lon": 0}
        if data is None
        else data.draw(_params_for(kind) if kind in catalog.KINDS else json_values)
    )
    try:
        valid = validate(kind, params, vessel_kind=vessel_kind)
    except CatalogError as exc:
        assert exc.message
        return
    # Whatever passes is normalised and passes again unchanged.
    assert validate(valid.kind, valid.params, vessel_kind=vessel_kind) == valid


@given(
    st.text(max_size=40)
    | st.builds(
        lambda w, a: f"#{w} {a}",
        st.sampled_from(sorted(catalog.SMS_WORDS)),
        st.text(alphabet="0123456789 -.eEnaONOFFLOPHD", max_size=20),
    )
)
def test_parse_text_raises_only_catalog_errors(text: str) -> None:
    try:
        valid = parse_text(text)
    except CatalogError:
        return
    assert parse_text(to_text(valid.kind, valid.params)).kind == valid.kind


def test_a_mission_end_defaults_from_loop_and_the_two_must_agree() -> None:
    item = [{"lat": 0, "lon": 0}]
    assert validate("mission", {"items": item}).params["end"] == "stop"
    looping = validate("mission", {"items": item, "loop": True}).params
    assert (looping["end"], looping["loop"]) == ("loop", True)
    home = validate("mission", {"items": item, "end": "return_home"}).params
    assert (home["end"], home["loop"]) == ("return_home", False)
    with pytest.raises(CatalogError, match="loop is true but end"):
        validate("mission", {"items": item, "loop": True, "end": "stop"})


def test_a_mission_item_speed_is_optional_and_ranged() -> None:
    item = {"lat": 0, "lon": 0, "speed_mps": 1.5}
    assert validate("mission", {"items": [item]}).params["items"][0]["speed_mps"] == 1.5
    assert (
        validate("mission", {"items": [{"lat": 0, "lon": 0}]}).params["items"][0]["speed_mps"]
        is None
    )
    with pytest.raises(CatalogError, match="speed_mps must be between 0.1 and 20"):
        validate("mission", {"items": [{**item, "speed_mps": 0}]})


def test_a_mission_items_fields_are_the_catalogs() -> None:
    from vessels.missions import ITEM_FIELDS

    assert tuple(p.name for p in catalog.MISSION_ITEM_PARAMS) == ITEM_FIELDS
