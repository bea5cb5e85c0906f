"""The command lifecycle table (docs/api.md#boat-api-v1), pure."""

from __future__ import annotations

import pytest

from commands.lifecycle import (
    FINAL,
    OPEN,
    TRANSITIONS,
    Status,
    TransitionError,
    ack_is_stale,
    can_transition,
    check_transition,
)

LEGAL = {
    (Status.QUEUED, Status.SENT),
    (Status.QUEUED, Status.CANCELLED),
    (Status.QUEUED, Status.SUPERSEDED),
    (Status.QUEUED, Status.EXPIRED),
    (Status.SENT, Status.ACKNOWLEDGED),
    (Status.SENT, Status.DONE),
    (Status.SENT, Status.FAILED),
    (Status.SENT, Status.CANCELLED),
    # The boat replaced it with a newer command (issue 16 §7): superseded, not failed.
    (Status.SENT, Status.SUPERSEDED),
    (Status.ACKNOWLEDGED, Status.DONE),
    (Status.ACKNOWLEDGED, Status.FAILED),
    (Status.ACKNOWLEDGED, Status.SUPERSEDED),
}


@pytest.mark.parametrize("current", list(Status))
@pytest.mark.parametrize("target", list(Status))
def test_it_allows_exactly_the_design_transitions(current: Status, target: Status) -> None:
    legal = (current, target) in LEGAL
    assert can_transition(current, target) is legal
    if legal:
        check_transition(current, target)
    else:
        with pytest.raises(TransitionError) as err:
            check_transition(current, target)
        assert (err.value.current, err.value.target) == (current, target)
        if target == Status.CANCELLED:
            assert str(err.value) == f"command is {current}; it can no longer be cancelled"
        else:
            assert str(err.value) == f"command is {current}; it cannot become {target}"


def test_it_has_a_row_for_every_status_and_no_way_out_of_a_final_one() -> None:
    assert set(TRANSITIONS) == set(Status)
    for status in FINAL:
        assert TRANSITIONS[status] == frozenset()
    assert set(OPEN) == {Status.QUEUED, Status.SENT}
    assert not set(OPEN) & FINAL


def test_it_never_lets_a_command_go_back_to_queued() -> None:
    assert all(Status.QUEUED not in targets for targets in TRANSITIONS.values())


@pytest.mark.parametrize(
    ("current", "reported", "stale"),
    [
        (Status.ACKNOWLEDGED, Status.ACKNOWLEDGED, True),
        (Status.DONE, Status.DONE, True),
        (Status.FAILED, Status.FAILED, True),
        (Status.DONE, Status.ACKNOWLEDGED, True),
        (Status.FAILED, Status.ACKNOWLEDGED, True),
        (Status.SENT, Status.ACKNOWLEDGED, False),
        (Status.ACKNOWLEDGED, Status.DONE, False),
        # A different final status is a conflict, not old news.
        (Status.DONE, Status.FAILED, False),
        (Status.FAILED, Status.DONE, False),
        (Status.CANCELLED, Status.DONE, False),
        (Status.QUEUED, Status.ACKNOWLEDGED, False),
    ],
)
def test_it_knows_a_repeated_or_trailing_ack_is_stale(
    current: Status, reported: Status, stale: bool
) -> None:
    assert ack_is_stale(current, reported) is stale
