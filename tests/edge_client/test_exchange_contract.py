"""edge_client.contract.exchange: what the boat reads from a telemetry answer (pure)."""

from __future__ import annotations

import json

from hypothesis import given
from hypothesis import strategies as st

from edge_client.contract import exchange

OLD = {"accepted": 1, "duplicates": 0, "rejected": []}


def test_an_answer_from_an_older_server_carries_no_exchange() -> None:
    assert exchange.list_in_answer(OLD) is None


def test_an_unchanged_list_is_its_etag_alone() -> None:
    assert exchange.list_in_answer({**OLD, "commands_etag": '"c1.2"'}) == ('"c1.2"', None)


def test_a_changed_list_comes_with_its_etag() -> None:
    answer = {**OLD, "commands": [{"uid": "u"}], "commands_etag": '"c1.3"'}
    assert exchange.list_in_answer(answer) == ('"c1.3"', [{"uid": "u"}])
    assert exchange.list_in_answer({**OLD, "commands": [], "commands_etag": '"c1.4"'}) == (
        '"c1.4"',
        [],
    )


def test_a_malformed_exchange_is_none_so_the_boat_polls() -> None:
    for bad in (
        {**OLD, "commands_etag": ""},
        {**OLD, "commands_etag": 3},
        {**OLD, "commands_etag": '"c1"', "commands": {"uid": "u"}},
        {**OLD, "commands_etag": '"c1"', "commands": None},
        [OLD],
        None,
    ):
        assert exchange.list_in_answer(bad) is None, bad


def test_the_boat_says_none_held_with_an_etag_that_matches_no_list() -> None:
    assert exchange.held_etag(None) == exchange.NONE_HELD == '""'
    assert exchange.held_etag('"c1.2"') == '"c1.2"'


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(), inner, max_size=4),
    max_leaves=20,
)


@given(JSON, st.one_of(st.none(), JSON), st.one_of(st.none(), JSON))
def test_any_json_answer_is_read_or_refused_never_a_crash(base, etag, commands) -> None:
    answer = base if not isinstance(base, dict) else dict(base)
    if isinstance(answer, dict):
        if etag is not None:
            answer[exchange.ETAG_KEY] = etag
        if commands is not None:
            answer[exchange.COMMANDS_KEY] = commands
    json.dumps(answer)  # a JSON value, as a server's answer parses to
    found = exchange.list_in_answer(answer)
    if found is not None:
        tag, listed = found
        assert isinstance(tag, str) and tag
        assert listed is None or isinstance(listed, list)
