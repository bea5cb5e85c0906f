"""Track simplification (telemetry/simplify.py): bounded, shape-keeping, gaps as breaks."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from telemetry.simplify import MIN_POINTS, gap_positions, simplify


def straight(n: int, *, step_s: float = 1.0) -> list[tuple[float, float, float]]:
    return [(i * step_s, -32 + i * 1e-5, 115.7 + i * 1e-5) for i in range(n)]


def flat(segments: list) -> list:
    return [p for s in segments for p in s]


def test_a_short_track_comes_back_whole_in_one_segment() -> None:
    points = straight(50)
    assert simplify(points, max_points=100, gap_s=10) == [points]


def test_a_long_track_is_cut_to_the_bound_keeping_its_ends_and_extremes() -> None:
    # A zig-zag survey: the turns are the extremes of each leg.
    points = [(float(i), -32 + (i % 200) * 1e-4, 115 + i * 1e-6) for i in range(20_000)]
    kept = flat(simplify(points, max_points=300, gap_s=10))
    assert len(kept) <= 300
    assert kept[0] == points[0] and kept[-1] == points[-1]
    assert max(points, key=lambda p: p[1]) in kept
    assert min(points, key=lambda p: p[1]) in kept


def test_a_silence_longer_than_gap_s_is_a_break_not_a_line() -> None:
    points = straight(10) + [(100.0 + i, -31.0, 116.0) for i in range(10)]
    segments = simplify(points, max_points=100, gap_s=5)
    assert len(segments) == 2
    assert segments[0][-1] == points[9] and segments[1][0] == points[10]


def test_breaks_can_be_given_for_points_that_are_not_consecutive_fixes() -> None:
    points = straight(10, step_s=60)  # far apart in time, but known to be one run
    assert len(simplify(points, max_points=100, gap_s=5, gaps=[])) == 1
    assert len(simplify(points, max_points=100, gaps=[4])) == 2


def test_a_bound_below_one_buckets_worth_is_refused() -> None:
    with pytest.raises(ValueError, match="at least"):
        simplify(straight(10), max_points=MIN_POINTS - 1, gap_s=5)


def test_an_empty_track_has_no_segments() -> None:
    assert simplify([], max_points=10, gap_s=5) == []


times = st.lists(st.floats(0, 1e6, allow_nan=False), min_size=1, max_size=400, unique=True)
coords = st.tuples(st.floats(-90, 90), st.floats(-180, 180))


@st.composite
def tracks(draw: st.DrawFn) -> list[tuple[float, float, float]]:
    ts = sorted(draw(times))
    return [(t, *draw(coords)) for t in ts]


@settings(max_examples=200, deadline=None)
@given(points=tracks(), max_points=st.integers(MIN_POINTS, 60), gap_s=st.floats(1, 1e5))
def test_simplify_properties(points: list, max_points: int, gap_s: float) -> None:
    segments = simplify(points, max_points=max_points, gap_s=gap_s)
    kept = flat(segments)
    # Bounded, a subsequence of the input in time order, all segments non-empty.
    assert len(kept) <= max_points
    assert all(segments)
    assert kept == sorted(kept) and set(kept) <= set(points)
    # The ends and the four extremes are always there.
    assert kept[0] == points[0] and kept[-1] == points[-1]
    for extreme in (
        max(points, key=lambda p: p[1]),
        min(points, key=lambda p: p[1]),
        max(points, key=lambda p: p[2]),
        min(points, key=lambda p: p[2]),
    ):
        assert any(p[1:] == extreme[1:] for p in kept)
    # No line crosses a gap: within a segment, no gap of the input lies between two neighbours.
    index = {p: i for i, p in enumerate(points)}
    gaps = gap_positions(points, gap_s)
    for segment in segments:
        for a, b in zip(segment, segment[1:], strict=False):
            assert not any(index[a] <= g < index[b] for g in gaps)
    # And every gap is a break, as long as some kept point lies on each side of it.
    breaks = len(segments) - 1
    crossed = {
        next(i for i, p in enumerate(kept) if index[p] > g) for g in gaps if index[kept[-1]] > g
    }
    assert breaks == len(crossed)


def test_extremes_hold_even_with_many_gaps() -> None:
    # Every fix its own segment (the vessel reports slower than its period): still bounded.
    points = [(i * 100.0, math.sin(i) * 10, math.cos(i) * 10) for i in range(1000)]
    kept = flat(simplify(points, max_points=50, gap_s=10))
    assert len(kept) <= 50
    assert max(points, key=lambda p: p[1]) in kept
