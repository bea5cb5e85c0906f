"""The SMS command language (sms/language.py): docs/sms.md's words and trial, one-SMS replies."""

from __future__ import annotations

import tomllib
from importlib import resources
from typing import Any

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from commands import catalog
from sms.gsm7 import ESCAPE, SMS_SEPTETS, encode, is_gsm7, septets
from sms.language import (
    MAX_COMMANDS,
    MAX_TEXT,
    NOT_ENABLED,
    Answer,
    Item,
    ItemKind,
    answer_command,
    answer_error,
    answer_help,
    compose_reply,
    parse,
)
from sms.level2.inner import InnerCommandTable

SHIPPED = InnerCommandTable.load()
CTRL_Z = 0x1A  # Ξ in the GSM-7 basic table; ends the text after the modem's prompt
PROVISIONAL = ("rudder", "ir", "holdwp", "fseq", "fcourse")


def table_with_enabled(*words: str) -> InnerCommandTable:
    """The shipped table with some provisional entries enabled (and given a value if none)."""
    data = tomllib.loads(
        resources.files("sms.level2").joinpath("inner_commands.toml").read_text("utf-8")
    )
    for word in words:
        entry = data["commands"][word]
        entry["enabled"] = True
        if word == "ir":
            entry["params"][0]["choices"] = {"on": 0x2004, "off": 0x2003}
        elif "value" not in entry and "value_from" not in entry and "value_by_sign" not in entry:
            entry["value"] = 0x0100
    return InnerCommandTable.from_dict(data)


ALL_ENABLED = table_with_enabled(*PROVISIONAL)


def one(text: str, table: InnerCommandTable | None = ALL_ENABLED) -> Item:
    items = parse(text, table=table)
    assert len(items) == 1, items
    return items[0]


def reply_to(items: list[Item]) -> str:
    """A reply as the service builds it, with QUEUED for commands and a fixed query answer."""
    answers = []
    for item in items:
        if item.kind == ItemKind.COMMAND:
            answers.append(answer_command(item, "QUEUED"))
        elif item.kind == ItemKind.HELP:
            answers.append(answer_help(item))
        elif item.kind == ItemKind.ERROR:
            answers.append(answer_error(item))
        else:
            answers.append(Answer(item.echo, "unknown"))
    return compose_reply(answers)


# --- docs/sms.md#the-language: every command and query ---


@pytest.mark.parametrize(
    ("text", "kind", "params", "echo"),
    [
        ("#FHEAD 230", "fhead", {"bearing": 230}, "#FHEAD 230"),
        ("#LIGHT ON", "light", {"state": "on"}, "#LIGHT ON"),
        ("#LIGHT off", "light", {"state": "off"}, "#LIGHT OFF"),
        ("#IR ON", "ir", {"state": "on"}, "#IR ON"),
        ("#HOLD", "hold", {}, "#HOLD"),
        (
            "#WAYPOINT 1 -32.0380 115.3325",
            "waypoint",
            {"index": 1, "lat": -32.038, "lon": 115.3325},
            "#WAYPOINT 1 -32.0380 115.3325",
        ),
        ("#HOLDWP 1", "holdwp", {"index": 1}, "#HOLDWP 1"),
        ("#FSEQ 1 1 4", "fseq", {"target": 1, "begin": 1, "end": 4}, "#FSEQ 1 1 4"),
        ("#RUDDER -30", "rudder", {"angle": -30}, "#RUDDER -30"),
        ("#RUDDER 30", "rudder", {"angle": 30}, "#RUDDER 30"),
        (
            "#FCOURSE LOOP 1 2 3",
            "fcourse",
            {"mode": "LOOP", "indices": [1, 2, 3]},
            "#FCOURSE LOOP 1 2 3",
        ),
    ],
)
def test_every_table_3_command_is_read_through_the_catalog(
    text: str, kind: str, params: dict[str, Any], echo: str
) -> None:
    item = one(text)
    assert (item.kind, item.command, dict(item.params), item.echo) == (
        ItemKind.COMMAND,
        kind,
        params,
        echo,
    )
    assert item.commanding


@pytest.mark.parametrize(
    ("text", "kind"),
    [
        ("#FHEAD", "fhead"),
        ("#LIGHT", "light"),
        ("#IR", "ir"),
        ("#WAYPOINT", "waypoint"),
        ("#HOLDWP", "holdwp"),
        ("#FSEQ", "fseq"),
        ("#RUDDER", "rudder"),
        ("#FCOURSE", "fcourse"),
    ],
)
def test_a_word_alone_is_a_query_and_commands_nothing(text: str, kind: str) -> None:
    item = one(text, table=SHIPPED)  # queries work whatever the table enables
    assert (item.kind, item.command, item.echo) == (ItemKind.QUERY, kind, text)
    assert not item.commanding


def test_hold_has_no_values_so_alone_it_is_a_command() -> None:
    assert one("#HOLD").kind == ItemKind.COMMAND


def test_status_and_help_are_understood() -> None:
    assert one("#status").kind == ItemKind.STATUS
    assert one("#STATUS now").error == "#STATUS takes no values"
    help_all = one("#HELP", table=SHIPPED)
    assert help_all.kind == ItemKind.HELP
    assert "#FHEAD" in help_all.answer and "#STATUS" in help_all.answer
    assert "#FSEQ" not in help_all.answer  # not enabled on this glider: not offered
    fseq = one("#help fseq", table=SHIPPED)
    assert fseq.answer.startswith(
        f"#FSEQ target begin end: Follow a waypoint sequence ({NOT_ENABLED})"
    )
    assert one("#HELP #FSEQ", table=ALL_ENABLED).answer.startswith("#FSEQ target begin end: Follow")
    assert one("#HELP FLY").error == "unknown command #FLY"


# --- docs/sms.md#the-2018-field-trial, in order, and its two failures ---

TABLE_4 = [
    ("#FHEAD 230", "#FHEAD 230"),
    ("#HOLD", "#HOLD"),
    ("#WAYPOINT 1 -32.0380 115.3325", "#WAYPOINT 1 -32.0380 115.3325"),
    ("#HOLDWP 1", "#HOLDWP 1"),
    ("#WAYPOINT 2 -32.0345 115.3326", "#WAYPOINT 2 -32.0345 115.3326"),
    ("#WAYPOINT 3 -32.0345 115.3326", "#WAYPOINT 3 -32.0345 115.3326"),
    ("#WAYPOINT 4 -32.0345 115.3326", "#WAYPOINT 4 -32.0345 115.3326"),
    ("#FSEQ 1 1 4", "#FSEQ 1 1 4"),
    ("#FCOURSE HOLD 3 4 1", "#FCOURSE HOLD 3 4 1"),
]


def test_table_4_in_order_with_the_provisional_entries_enabled() -> None:
    for text, echo in TABLE_4:
        item = one(text)
        assert item.kind == ItemKind.COMMAND, (text, item.error)
        assert reply_to([item]) == f"{echo} QUEUED"


def test_table_4_in_order_with_the_shipped_table() -> None:
    replies = [reply_to(parse(text, table=SHIPPED)) for text, _ in TABLE_4]
    assert replies == [
        "#FHEAD 230 QUEUED",
        "#HOLD QUEUED",
        "#WAYPOINT 1 -32.0380 115.3325 QUEUED",
        f"#HOLDWP 1 ERR {NOT_ENABLED}",
        "#WAYPOINT 2 -32.0345 115.3326 QUEUED",
        "#WAYPOINT 3 -32.0345 115.3326 QUEUED",
        "#WAYPOINT 4 -32.0345 115.3326 QUEUED",
        f"#FSEQ 1 1 4 ERR {NOT_ENABLED}",
        f"#FCOURSE HOLD 3 4 1 ERR {NOT_ENABLED}",
    ]


def test_regression_holdwp_1_is_holdwp_never_hold() -> None:
    # Field trial, 12:09: "#HOLDWP 1 … perhaps misinterpreted as #HOLD".
    item = one("#HOLDWP 1")
    assert (item.command, dict(item.params)) == ("holdwp", {"index": 1})
    assert reply_to([item]) == "#HOLDWP 1 QUEUED"


def test_regression_the_reply_to_fseq_1_1_4_carries_all_three_values() -> None:
    # Field trial, 12:28: the reply came back as "#FSEQ 1 1", the last value lost.
    assert reply_to([one("#FSEQ 1 1 4")]) == "#FSEQ 1 1 4 QUEUED"
    assert reply_to(parse("#FSEQ 1 1 4", table=SHIPPED)) == f"#FSEQ 1 1 4 ERR {NOT_ENABLED}"


def test_a_short_fseq_is_refused_not_sent_short() -> None:
    item = one("#FSEQ 1 1")
    assert item.kind == ItemKind.ERROR
    assert reply_to([item]).startswith("#FSEQ 1 1 ERR #FSEQ needs end")


# --- the inner command table: refused at once, enabled by the table alone ---


@pytest.mark.parametrize(
    "text", ["#RUDDER 10", "#IR ON", "#HOLDWP 1", "#FSEQ 1 1 4", "#FCOURSE LOOP 1 2"]
)
def test_provisional_commands_are_refused_until_the_table_enables_them(text: str) -> None:
    refused = one(text, table=SHIPPED)
    assert (refused.kind, refused.error) == (ItemKind.ERROR, NOT_ENABLED)
    assert refused.echo == text  # every value echoed
    word = refused.command
    enabled = one(text, table=table_with_enabled(word))
    assert enabled.kind == ItemKind.COMMAND
    assert enabled.echo == text


def test_the_table_limits_what_the_catalog_allows() -> None:
    # The catalog takes any number of indices; the table fits at most 4 in the packet.
    item = one("#FCOURSE LOOP 1 2 3 4 5")
    assert item.kind == ItemKind.ERROR
    assert item.error == "indices takes 1–4 values, got 5"
    assert reply_to([item]) == "#FCOURSE LOOP 1 2 3 4 5 ERR indices takes 1-4 values, got 5"


def test_without_a_table_the_catalog_alone_decides() -> None:
    assert one("#FSEQ 1 1 4", table=None).kind == ItemKind.COMMAND


# --- whole words, case, spaces, several commands ---


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("#IRX", "unknown command #IRX"),
        ("#IRX ON", "unknown command #IRX"),
        ("#HOLDWP1", "unknown command #HOLDWP1"),
        ("#HOL", "unknown command #HOL"),
        ("#FHEADING 230", "unknown command #FHEADING"),
        ("#LIGHTS ON", "unknown command #LIGHTS"),
        ("FHEAD 230", "a command starts with # (for example #FHEAD 230)"),
    ],
)
def test_words_match_whole_never_by_prefix(text: str, error: str) -> None:
    item = one(text)
    assert (item.kind, item.error) == (ItemKind.ERROR, error)


def test_hold_with_values_is_not_holdwp() -> None:
    item = one("#HOLD 1")
    assert item.kind == ItemKind.ERROR
    assert "extra: 1" in item.error
    assert item.commanding  # a query-role number may not try it either


def test_case_and_extra_spaces_are_forgiven() -> None:
    assert one("   #fHeAd      230   ").echo == "#FHEAD 230"
    assert one("#light\ton").echo == "#LIGHT ON"


def test_several_commands_one_per_line_or_separated_by_semicolons() -> None:
    items = parse(
        "#WAYPOINT 1 -32.0380 115.3325\n#holdwp 1 ; #LIGHT on;;\r\n#STATUS", table=ALL_ENABLED
    )
    assert [(i.kind, i.echo) for i in items] == [
        (ItemKind.COMMAND, "#WAYPOINT 1 -32.0380 115.3325"),
        (ItemKind.COMMAND, "#HOLDWP 1"),
        (ItemKind.COMMAND, "#LIGHT ON"),
        (ItemKind.STATUS, "#STATUS"),
    ]
    assert reply_to(items) == (
        "#WAYPOINT 1 -32.0380 115.3325 QUEUED; #HOLDWP 1 QUEUED; #LIGHT ON QUEUED; #STATUS unknown"
    )


def test_a_bad_command_does_not_lose_the_good_ones_beside_it() -> None:
    items = parse("#FHEAD 400; #LIGHT ON", table=SHIPPED)
    assert [i.kind for i in items] == [ItemKind.ERROR, ItemKind.COMMAND]


def test_at_most_ten_commands_are_read_and_the_rest_refused_together() -> None:
    items = parse(";".join(f"#FHEAD {i}" for i in range(MAX_COMMANDS + 3)), table=SHIPPED)
    assert len(items) == MAX_COMMANDS + 1
    assert items[-1].error == f"3 more not read: at most {MAX_COMMANDS} per SMS"


# --- identical commands in one SMS (issue 16 §6) ---


def test_twelve_identical_commands_are_one_command_and_the_reply_says_so() -> None:
    items = parse(";".join(["#HOLD"] * 12), table=SHIPPED)
    assert [(i.kind, i.command, i.repeats) for i in items] == [(ItemKind.COMMAND, "hold", 12)]
    assert items[0].as_dict()["repeats"] == 12
    assert reply_to(items) == "#HOLD QUEUED (12 identical commands in this SMS taken once)"


def test_commands_are_identical_by_kind_and_values_whatever_their_spelling() -> None:
    items = parse(
        "#WAYPOINT 1 -32.0380 115.3325\n#waypoint 1 32 02.28S 115 19.95E; #WAYPOINT 2 -32 115",
        table=SHIPPED,
    )
    assert [(i.echo, i.repeats) for i in items] == [
        ("#WAYPOINT 1 -32.0380 115.3325", 2),
        ("#WAYPOINT 2 -32.0000 115.0000", 1),
    ]


def test_a_repeated_command_stands_where_it_was_given_last_so_the_sms_ends_as_asked() -> None:
    items = parse("#LIGHT ON; #LIGHT OFF; #LIGHT ON; #HOLD; #FHEAD 230; #HOLD", table=SHIPPED)
    assert [(i.echo, i.repeats) for i in items] == [
        ("#LIGHT OFF", 1),
        ("#LIGHT ON", 2),
        ("#FHEAD 230", 1),
        ("#HOLD", 2),
    ]


def test_repeats_of_a_command_read_do_not_count_towards_the_ten() -> None:
    text = ";".join(["#HOLD"] * 5 + [f"#FHEAD {i}" for i in range(MAX_COMMANDS)] + ["#HOLD"])
    items = parse(text, table=SHIPPED)
    assert len(items) == MAX_COMMANDS + 1
    assert items[-1].error == f"1 more not read: at most {MAX_COMMANDS} per SMS"
    assert (items[-2].echo, items[-2].repeats) == ("#HOLD", 6)
    assert "#FHEAD 9" not in [i.echo for i in items]


def test_queries_and_refusals_are_never_merged() -> None:
    items = parse("#LIGHT; #LIGHT; #RUDDER 45; #RUDDER 45", table=SHIPPED)
    assert [(i.kind, i.repeats) for i in items] == [
        (ItemKind.QUERY, 1),
        (ItemKind.QUERY, 1),
        (ItemKind.ERROR, 1),
        (ItemKind.ERROR, 1),
    ]


@given(st.lists(st.sampled_from(["#LIGHT ON", "#light on", "#LIGHT OFF", "#HOLD", "#FHEAD 230",
                                  "#FHEAD 10", "#IR ON", "#WAYPOINT 1 -32 115"]), min_size=1,
                max_size=40))  # fmt: skip
def test_merging_keeps_each_kinds_last_order_and_counts_every_command(texts: list[str]) -> None:
    items = parse(";".join(texts), table=ALL_ENABLED)  # at most 8 distinct: all read
    alone = [one(t) for t in texts]
    last = {i.command: (i.command, dict(i.params)) for i in alone}
    assert {i.command: (i.command, dict(i.params)) for i in items} == last
    assert sum(i.repeats for i in items) == len(texts)
    keys = [(i.command, repr(i.params)) for i in items]
    assert len(set(keys)) == len(keys)
    where = [max(n for n, a in enumerate(alone) if (a.command, repr(a.params)) == k) for k in keys]
    assert where == sorted(where)  # each where it was given last, in that order


def test_the_note_on_repeats_stays_within_one_sms() -> None:
    text = "\n".join(f"#WAYPOINT {i} -32.0345 115.3326\n#WAYPOINT {i} -32.0345 115.3326"
                     for i in range(1, 9))  # fmt: skip
    reply = reply_to(parse(text, table=SHIPPED))
    assert typeable_sms(reply)
    assert reply.startswith("#WAYPOINT 1 -32.0345 115.3326 QUEUED (2 identical commands in this")


def test_an_empty_or_oversized_message_is_one_error() -> None:
    assert one("  \n ; ").error == "empty message; send #HELP for the commands"
    huge = one("#FHEAD 230 " * (MAX_TEXT // 10))
    assert huge.kind == ItemKind.ERROR and "message too long" in huge.error


# --- ranges and index limits ---


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("#RUDDER 45", "angle must be between -30 and 30 (got 45)"),
        ("#RUDDER -31", "angle must be between -30 and 30 (got -31)"),
        ("#FHEAD 360", "bearing must be between 0 and 359 (got 360)"),
        ("#FHEAD -1", "bearing must be between 0 and 359 (got -1)"),
        ("#FHEAD east", "bearing must be a number (got 'east')"),
        ("#HOLDWP 0", "index must be between 1 and 254 (got 0)"),
        ("#HOLDWP 255", "index must be between 1 and 254 (got 255)"),
        ("#FSEQ 1 1 255", "end must be between 1 and 254 (got 255)"),
        ("#FCOURSE LOOP 1 0", "indices must be between 1 and 254 (got 0)"),
        ("#WAYPOINT 255 -32 115", "index must be between 1 and 254 (got 255)"),
        ("#WAYPOINT 1 -91 115", "lat must be between -90 and 90 (got -91)"),
        ("#WAYPOINT 1 -32 181", "lon must be between -180 and 180 (got 181)"),
        ("#LIGHT DIM", "state must be one of on, off"),
    ],
)
def test_every_error_names_what_was_wrong(text: str, error: str) -> None:
    item = one(text)
    assert item.kind == ItemKind.ERROR
    assert item.error == error
    assert reply_to([item]) == f"{text} ERR {error}"


@pytest.mark.parametrize("index", [1, 2, 253, 254])
def test_indices_1_to_254_are_accepted(index: int) -> None:
    assert one(f"#HOLDWP {index}").params == {"index": index}
    assert one(f"#FSEQ {index} 1 {index}").kind == ItemKind.COMMAND


# --- coordinates ---


@pytest.mark.parametrize(
    "coordinates",
    [
        "-32.0380 115.3325",
        "32.0380S 115.3325E",
        "32.038s 115.3325e",
        "32 02.28S 115 19.95E",
        "-32 02.280 115 19.950",
        "32°02.28'S 115°19.95'E",
        "32° 02.28' S 115° 19.95' E",
    ],
)
def test_coordinates_in_decimal_degrees_or_degrees_and_minutes(coordinates: str) -> None:
    item = one(f"#WAYPOINT 1 {coordinates}")
    assert item.kind == ItemKind.COMMAND, item.error
    assert item.params["lat"] == pytest.approx(-32.038)
    assert item.params["lon"] == pytest.approx(115.3325)
    assert item.echo == "#WAYPOINT 1 -32.0380 115.3325"


def test_northern_and_western_hemispheres() -> None:
    item = one("#WAYPOINT 7 50 30.0N 4 15.0W")
    assert (item.params["lat"], item.params["lon"]) == (pytest.approx(50.5), pytest.approx(-4.25))


@pytest.mark.parametrize(
    ("coordinates", "error"),
    [
        ("32 61.0S 115 19.95E", "lat minutes must be below 60 (got 61.0)"),
        ("-32.038S 115.3325", "lat: give a sign or N/S, not both"),
        ("32.038E 115.3325", "lat takes N or S, not E"),
        ("-32.038 115.3325N", "lon takes E or W, not N"),
        ("-32 02.28 115", "give lat lon as -32.0380 115.3325 or 32 02.28S 115 19.95E"),
        ("32.5 02.28S 115 19.95E", "lat must be degrees and minutes as in"),
    ],
)
def test_coordinate_mistakes_are_named(coordinates: str, error: str) -> None:
    item = one(f"#WAYPOINT 1 {coordinates}")
    assert item.kind == ItemKind.ERROR
    assert error in item.error


@pytest.mark.parametrize(
    ("text", "error"),
    [
        # issue 16 §15: was "lon takes E or W, not S"
        ("#WAYPOINT 1 32 02.28S", "longitude missing"),
        ("#WAYPOINT 1 32 02.28 S", "longitude missing"),
        ("#WAYPOINT 1 -32.0380", "longitude missing"),
        ("#WAYPOINT 1 32.0380S", "longitude missing"),
        ("#WAYPOINT 1 115.3325E", "latitude missing"),
        ("#WAYPOINT 1 115 19.95E", "latitude missing"),
        ("#WAYPOINT 1", "latitude and longitude missing"),
        ("#WAYPOINT 1 32.038S 115.3325E 7", "#WAYPOINT takes index lat lon; extra: 7"),
        ("#WAYPOINT 1 32 02.28S 115 19.95E 7 8", "#WAYPOINT takes index lat lon; extra: 7 8"),
        ("#WAYPOINT 1 -32 02.28 115 19.95 7", "#WAYPOINT takes index lat lon; extra: 7"),
        (
            "#WAYPOINT 1 -32 02.28 115",
            "3 values for lat lon: give lat lon as -32.0380 115.3325 or 32 02.28S 115 19.95E",
        ),
        ("#WAYPOINT x 32 02.28S", "index must be a number (got 'x')"),
    ],
)
def test_a_missing_or_extra_coordinate_is_named(text: str, error: str) -> None:
    item = one(text)
    assert (item.kind, item.error) == (ItemKind.ERROR, error)
    assert reply_to([item]) == f"{text} ERR {error}"


def test_a_decimal_pair_is_still_a_pair_when_the_latitude_could_be_degrees() -> None:
    item = one("#WAYPOINT 1 32 19.95E")  # 32° N, 19.95° E: a whole decimal position
    assert (item.kind, item.params["lat"], item.params["lon"]) == (ItemKind.COMMAND, 32, 19.95)


# --- replies: one SMS, every value, GSM-7 ---


def test_a_reply_that_cannot_fit_keeps_whole_answers_and_counts_the_rest() -> None:
    items = parse("\n".join(f"#WAYPOINT {i} -32.0345 115.3326" for i in range(1, 9)), table=SHIPPED)
    text = reply_to(items)
    assert septets(text) <= SMS_SEPTETS
    kept = text.split("; ")
    assert kept[-1] == f"+{len(items) - len(kept) + 1} more"
    for part in kept[:-1]:
        assert part.endswith(" 115.3326 QUEUED")  # never cut in the middle


def test_the_note_counts_errors_left_out() -> None:
    answers = [Answer(f"#WAYPOINT {i} -32.0345 115.3326", "QUEUED") for i in range(1, 6)]
    answers.append(Answer("#FHEAD 400", "ERR bearing must be between 0 and 359", error=True))
    assert compose_reply(answers).endswith("; +3 more (1 ERR)")


def test_an_echo_too_long_for_one_sms_is_shortened_at_a_value_boundary() -> None:
    # Without the table the catalog accepts any number of indices.
    item = one("#FCOURSE LOOP " + " ".join(str(i) for i in range(1, 80)), table=None)
    text = reply_to([item])
    assert septets(text) <= SMS_SEPTETS
    assert text.endswith(" more QUEUED")
    values = text.split()[2:-3]
    assert values == [str(i) for i in range(1, len(values) + 1)]


def typeable_sms(text: str) -> bool:
    """One SMS of GSM-7 that a text-mode modem can type after its prompt (no ESC, no Ctrl-Z)."""
    return (
        is_gsm7(text)
        and not {ESCAPE, CTRL_Z} & set(encode(text))
        and 0 < septets(text) <= SMS_SEPTETS
    )


def test_non_gsm_text_never_gives_a_non_gsm_reply() -> None:
    text = reply_to(parse("#FHEAD 230 😀; #ФЛАГ; #LIGHT ‘on’", table=SHIPPED))
    assert typeable_sms(text)
    assert text.startswith("#FHEAD 230 ? ERR #FHEAD takes 1 value(s); extra: ?")


def test_characters_a_modem_cannot_type_are_spelled_plainly() -> None:
    # The extension table needs ESC and Ξ is Ctrl-Z: typed after "> " they cancel or send.
    text = reply_to(parse("#FHEAD [230] {x} ~|\\^ €Ξ", table=SHIPPED))
    assert typeable_sms(text)
    assert "(230) (x) -//' EUR?" in text


commands_text = st.builds(
    lambda word, values: f"#{word} {values}",
    st.sampled_from([*catalog.SMS_WORDS, "STATUS", "HELP", "HOLDW", "IRX"]),
    st.text(alphabet="0123456789 -.,°'NSEWnsewONOFFLOPHD#;\n", max_size=40),
)


@given(st.text(max_size=300) | commands_text | st.lists(commands_text, max_size=14).map("\n".join))
@example("#FSEQ 1 1 4")
@example("#" + "W" * 400)
@example("#FCOURSE LOOP " + "1 " * 300)
@example("😀" * 200)
def test_any_text_gives_items_and_a_one_sms_gsm_reply_never_an_exception(text: str) -> None:
    for table in (SHIPPED, ALL_ENABLED, None):
        items = parse(text, table=table)
        assert items
        for item in items:
            assert item.kind != ItemKind.ERROR or item.error  # a rejection always says why
            if item.kind == ItemKind.COMMAND:  # a command echoes every value
                valid = catalog.parse_text(item.echo)
                assert (valid.kind, valid.params) == (item.command, dict(item.params))
        reply = reply_to(items)
        assert typeable_sms(reply)


def test_the_plain_text_fast_path_passes_only_one_septet_gsm_characters() -> None:
    import string

    from sms.gsm7 import BASIC
    from sms.language import _PLAIN

    for ch in string.printable:
        if _PLAIN.fullmatch(ch):
            assert ch in BASIC and septets(ch) == 1, ch
    assert not _PLAIN.fullmatch("`") and not _PLAIN.fullmatch("[")
