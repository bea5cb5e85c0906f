"""Min/max downsampling for plots (telemetry/series.py) and the overview's merge arithmetic
(telemetry/overview.py): a spike never disappears, buckets merge exactly."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from telemetry.overview import RAW, WIDTHS, cover, merge, summarize
from telemetry.series import Downsampler, bucket_count, bucket_width, downsample


def test_a_spike_survives_as_its_buckets_max() -> None:
    samples = [(float(t), 12.0) for t in range(86400)]
    samples[40_000] = (40_000.0, 99.0)
    series = downsample(samples, start=0, end=86400, max_buckets=100)
    assert series["bucket_s"] == 900  # 86,400 / 100 = 864 → the next nice width
    assert len(series["t"]) == 96
    assert max(series["max"]) == 99.0
    assert min(series["min"]) == 12.0
    assert series["count"][40_000 // 900] == 900


def test_buckets_are_aligned_to_the_epoch_and_empty_ones_are_none() -> None:
    series = downsample([(125.0, 1.0), (130.0, 3.0)], start=100, end=400, max_buckets=4)
    assert (series["bucket_s"], series["t"]) == (120, [0, 120, 240, 360])
    filled = [i for i, c in enumerate(series["count"]) if c]
    assert len(filled) == 1
    i = filled[0]
    assert (series["min"][i], series["max"][i], series["mean"][i]) == (1.0, 3.0, 2.0)
    assert all(series["min"][j] is None for j in range(len(series["t"])) if j != i)


def test_samples_outside_the_range_are_left_out() -> None:
    series = downsample([(99.0, 50.0), (100.0, 1.0), (200.0, 60.0)], start=100, end=200,
                        max_buckets=10)  # fmt: skip
    assert max(v for v in series["max"] if v is not None) == 1.0


def test_a_bucket_count_below_one_is_refused() -> None:
    with pytest.raises(ValueError, match="at least 1"):
        bucket_width(0, 100, 0)


@settings(max_examples=200, deadline=None)
@given(
    samples=st.lists(st.tuples(st.floats(0, 1e6), st.floats(-1e6, 1e6)), min_size=1, max_size=300),
    max_buckets=st.integers(1, 200),
)
def test_downsampling_keeps_every_extreme_and_count(samples: list, max_buckets: int) -> None:
    series = downsample(samples, start=0, end=1e6 + 1, max_buckets=max_buckets)
    assert len(series["t"]) <= max_buckets
    assert sum(series["count"]) == len(samples)
    assert max(v for v in series["max"] if v is not None) == max(v for _, v in samples)
    assert min(v for v in series["min"] if v is not None) == min(v for _, v in samples)
    width = series["bucket_s"]
    for t, value in samples:
        i = int(t // width) - series["t"][0] // width
        assert series["min"][i] <= value <= series["max"][i]


@given(start=st.floats(0, 1e9), span=st.floats(1, 1e8), n=st.integers(1, 5000))
def test_the_nice_width_gives_at_most_n_buckets(start: float, span: float, n: int) -> None:
    assert bucket_count(start, start + span, bucket_width(start, start + span, n)) <= n


def test_aggregates_add_like_their_samples() -> None:
    sampler = Downsampler(0, 3600, 600)
    sampler.add_aggregate("x", 60, 1.0, 5.0, 9.0, 3)
    sampler.add("x", 100, 7.0)
    channel = sampler.channels["x"]
    assert (channel.min[0], channel.max[0], channel.count[0]) == (1.0, 7.0, 4)
    assert channel.mean[0] == 4.0
    assert channel.mean[1] is None


fixes = st.lists(
    st.tuples(
        st.integers(0, 7200),
        st.floats(-90, 90),
        st.floats(-180, 180),
        st.none() | st.floats(0, 30),
        st.dictionaries(st.sampled_from(["a", "b"]), st.floats(-5, 5), max_size=2),
    ),
    min_size=1,
    max_size=200,
    unique_by=lambda f: f[0],
)


@settings(max_examples=100, deadline=None)
@given(raw=fixes)
def test_a_bucket_merged_from_minutes_equals_one_built_from_raw(raw: list) -> None:
    raw = sorted((float(t), *rest) for t, *rest in raw)
    minutes: dict[int, list] = {}
    for f in raw:
        minutes.setdefault(int(f[0] // 60 * 60), []).append(f)
    parts = [summarize(start, group) for start, group in sorted(minutes.items())]
    merged, direct = merge(0, parts), summarize(0, raw)
    assert merged.count == direct.count == len(raw)
    assert (merged.first, merged.last) == (direct.first, direct.last)
    assert (merged.north[1], merged.south[1]) == (direct.north[1], direct.south[1])
    assert (merged.east[2], merged.west[2]) == (direct.east[2], direct.west[2])
    assert merged.gap_s == direct.gap_s
    assert merged.channels.keys() == direct.channels.keys()
    for key, (low, high, total, count) in direct.channels.items():
        m = merged.channels[key]
        assert (m[0], m[1], m[3]) == (low, high, count)
        assert math.isclose(m[2], total, abs_tol=1e-6)


@given(start=st.floats(0, 1e7), span=st.floats(0, 1e6), level=st.integers(-1, len(WIDTHS) - 1))
def test_a_cover_tiles_the_range_with_whole_buckets(start: float, span: float, level: int) -> None:
    pieces = cover(start, start + span, level)
    assert bool(pieces) == (start + span > start)
    if pieces:
        assert pieces[0][1] == start and pieces[-1][2] == start + span
        for (_w1, _a1, b1), (_w2, a2, _b2) in zip(pieces, pieces[1:], strict=False):
            assert b1 == a2
        for width, a, b in pieces:
            assert a < b
            if width:
                assert a % width == 0 and b % width == 0


@given(
    start=st.floats(0, 1e5),
    span=st.floats(0, 2e4),
    level=st.integers(-1, len(WIDTHS) - 1),
    dirty=st.sets(st.integers(0, 2000)),
)
def test_a_cover_reads_dirty_minutes_raw_and_no_bucket_over_them(
    start: float, span: float, level: int, dirty: set[int]
) -> None:
    minutes = sorted(m * WIDTHS[0] for m in dirty)
    pieces = cover(start, start + span, level, minutes)
    assert bool(pieces) == (start + span > start)
    if not pieces:
        return
    assert pieces[0][1] == start and pieces[-1][2] == start + span
    for (w1, _a1, b1), (w2, a2, _b2) in zip(pieces, pieces[1:], strict=False):
        assert b1 == a2
        assert not w1 == w2 == RAW  # neighbouring raw reads are one read
    for width, a, b in pieces:
        assert a < b
        if width:
            assert a % width == 0 and b % width == 0
            assert not any(a <= m < b for m in minutes)
    raw = [(a, b) for width, a, b in pieces if width == RAW]
    for m in minutes:
        lo, hi = max(m, start), min(m + WIDTHS[0], start + span)
        if lo < hi:
            assert any(a <= lo and hi <= b for a, b in raw)
