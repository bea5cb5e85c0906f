"""Retention's arithmetic (telemetry/thinning.py): first and last of each interval, kept fixes
never deleted, the same answer in any chunks, and thinning twice changes nothing."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from telemetry.thinning import Row, Thinner, interval_start, thin

INTERVAL = 60


def rows_from(times: list[int], kept: frozenset[int] = frozenset()) -> list[Row]:
    return [(i + 1, float(t), i + 1 in kept) for i, t in enumerate(sorted(set(times)))]


def survivors(rows: list[Row], interval: int = INTERVAL) -> list[Row]:
    doomed = set(thin(rows, interval))
    return [r for r in rows if r[0] not in doomed]


def test_it_keeps_the_first_and_last_fix_of_each_interval() -> None:
    rows = rows_from([0, 10, 20, 30, 59, 60, 61, 125, 179, 180])
    assert [t for _, t, _ in survivors(rows)] == [0, 59, 60, 61, 125, 179, 180]


def test_a_kept_fix_stays_and_the_ones_around_it_go() -> None:
    rows = rows_from([0, 10, 20, 30, 40, 50], kept=frozenset({3}))  # the fix at 20 s
    assert [t for _, t, _ in survivors(rows)] == [0, 20, 50]


def test_intervals_are_aligned_on_unix_time() -> None:
    assert interval_start(3599.5, 3600) == 0
    assert interval_start(3600, 3600) == 3600
    assert interval_start(-0.5, 60) == -60


times_st = st.lists(st.integers(min_value=0, max_value=2000), min_size=0, max_size=200)
intervals_st = st.sampled_from([1, 7, 60, 300])


@given(times_st, intervals_st, st.data())
def test_an_interval_keeps_its_first_its_last_and_its_kept_fixes(
    times: list[int], interval: int, data: st.DataObject
) -> None:
    rows = rows_from(times)
    kept = data.draw(st.frozensets(st.sampled_from([r[0] for r in rows]))) if rows else set()
    rows = [(i, t, i in kept) for i, t, _ in rows]
    left = survivors(rows, interval)
    by_interval: dict[int, list[Row]] = {}
    for row in rows:
        by_interval.setdefault(interval_start(row[1], interval), []).append(row)
    expected = set()
    for group in by_interval.values():
        expected |= {group[0][0], group[-1][0]} | {r[0] for r in group if r[2]}
    assert {r[0] for r in left} == expected


@given(times_st, intervals_st, st.lists(st.integers(min_value=1, max_value=50)))
def test_chunks_give_the_same_answer_as_the_whole_stream(
    times: list[int], interval: int, cuts: list[int]
) -> None:
    rows = rows_from(times)
    thinner, doomed, at = Thinner(interval), [], 0
    for size in [*cuts, len(rows)]:
        doomed += thinner.feed(rows[at : at + size])
        at += size
    assert doomed == thin(rows, interval)


@given(times_st, intervals_st)
def test_thinning_twice_changes_nothing(times: list[int], interval: int) -> None:
    once = survivors(rows_from(times), interval)
    assert thin(once, interval) == []


@given(times_st, intervals_st, st.integers(min_value=0, max_value=200))
def test_resuming_at_the_open_interval_decides_the_same(
    times: list[int], interval: int, stop_after: int
) -> None:
    """A prune stopped after some rows (their deletions done) and started again at the open
    interval's start ends where one uninterrupted prune ends."""
    rows = rows_from(times)
    first = Thinner(interval)
    doomed = set(first.feed(rows[:stop_after]))
    left = [r for r in rows if r[0] not in doomed]
    resume_at = first.open_start if first.open_start is not None else float("-inf")
    doomed |= set(Thinner(interval).feed([r for r in left if r[1] >= resume_at]))
    assert sorted(doomed) == sorted(thin(rows, interval))
