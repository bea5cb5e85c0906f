"""The one rule for a boat's strings (vessels/text.py). Pure."""

from __future__ import annotations

from typing import Any

import pytest

from vessels.text import JSON_MAX_DEPTH, json_size, json_unstorable, shown, unstorable


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("plain, ünïcödé and 😀", None),
        ("\ufffd", None),
        ("a\x00b", "Null characters are not allowed."),
        ("a\ud800", "Surrogate characters are not allowed: U+D800."),
        ("\udfff", "Surrogate characters are not allowed: U+DFFF."),
    ],
)
def test_unstorable_names_nul_and_lone_surrogates_only(text: str, problem: str | None) -> None:
    assert unstorable(text) == problem


@pytest.mark.parametrize(
    ("value", "where"),
    [
        ([{"k": "ok"}, 1, None, True, 2.5], None),
        ("a\x00", "value: Null"),
        ([{"k": "a\x00b"}], "[0].k: Null"),
        ({"a": [{"b": ["ok", "\ud800"]}]}, "a[0].b[1]: Surrogate"),
        ({"a\x00": 1}, "key 'a\\x00': Null"),
        ({"a": {"\ud800": 1}}, "key '\\ud800' in a: Surrogate"),
        ([{"first": "\x00"}, {"second": "\x00"}], "[0].first: Null"),
    ],
)
def test_json_unstorable_names_where_the_first_problem_is(value: Any, where: str | None) -> None:
    found = json_unstorable(value)
    assert found == where if where is None else found.startswith(where)


def test_json_unstorable_refuses_nesting_past_its_limit_without_recursing() -> None:
    # 5,000 levels: past Python's recursion limit, which a recursive walk would hit.
    deep: Any = "ok"
    for _ in range(5000):
        deep = [deep]
    limit = JSON_MAX_DEPTH
    assert json_unstorable(deep) == "[0]" * limit + f": nested deeper than {limit} levels"


def test_json_unstorable_takes_nesting_up_to_its_limit() -> None:
    deep: Any = {"k": "ok"}
    for _ in range(JSON_MAX_DEPTH - 1):
        deep = [deep]
    assert json_unstorable(deep) is None
    assert json_unstorable([deep]) is not None


def test_json_size_counts_compact_utf8() -> None:
    assert json_size({"a": "é"}) == len('{"a":"é"}'.encode())
    assert json_size(["\x01"]) == len('["\\u0001"]')


def test_shown_spells_what_a_reply_cannot_carry() -> None:
    assert shown("a\x00b\ud800") == "a\\x00b\\ud800"
