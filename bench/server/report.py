"""Reporting: the figures table (each figure beside its baselines and target), notes, profiles."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from bench.server.constants import FIXES_PER_POST
from bench.server.stack import Stack
from bench.server.wrk import WrkResult


@dataclass
class Figures:
    rows: list[tuple[str, str, str, str, str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    stored: dict[str, int] = field(default_factory=dict)

    def row(
        self,
        name: str,
        value: str,
        drf: str = "",
        bare: str = "",
        target: str = "",
        verdict: bool | None = None,
    ) -> None:
        mark = "" if verdict is None else ("PASS" if verdict else "MISS")
        self.rows.append((name, value, drf, bare, target, mark))
        print(f"    {name}: {value}  | DRF {drf or '-'} | bare {bare or '-'} | {target} {mark}")


def fmt(n: float, digits: int = 0) -> str:
    return f"{n:,.{digits}f}"


def check_wrk(name: str, r: WrkResult, figures: Figures) -> None:
    if r.bad or r.errors:
        figures.notes.append(
            f"{name}: {r.bad} unexpected answers, {r.errors} socket errors/timeouts of "
            f"{r.requests} (first: {r.first_bad[:120]})"
        )


def percentile(values: list[float], q: float) -> float:
    if not values:
        return 0.0
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def count_stored(stack: Stack, figures: Figures) -> None:
    counts = stack.helper("count")
    soak_fixes = sum(v for s, v in counts.items() if s.startswith("boat-"))
    expected = dict(figures.stored)
    soak_posts = expected.pop("soak-posts", 0)
    lines = []
    for slug, answered in expected.items():
        lines.append(f"{slug} {counts.get(slug, 0)}/{answered}")
        if counts.get(slug, 0) < answered:
            figures.notes.append(f"LOST FIXES: {slug} stored {counts.get(slug)} < {answered}")
    lines.append(f"mixed-run boats {soak_fixes}/{soak_posts * FIXES_PER_POST}")
    if soak_fixes < soak_posts * FIXES_PER_POST:
        figures.notes.append("LOST FIXES in the mixed run")
    figures.notes.append(
        "fixes stored / answered as accepted, warm-ups included (stored may exceed: wrk "
        "drops the answers still in flight when it stops): " + ", ".join(lines)
    )


def print_table(stack: Stack, figures: Figures, elapsed: float) -> None:
    server = f"gunicorn 2 x {stack.worker_class}"
    if stack.worker_class == "gthread":
        server += f" ({stack.threads} threads)"
    title = f"{stack.label}, {server}, wrk -t1 on the same 2 cores"
    headers = ("figure", "shoreside", "DRF baseline", "bare Django", "target", "")
    widths = [max(len(str(r[i])) for r in [headers, *figures.rows]) for i in range(6)]
    print()
    print("=" * len(title))
    print(title)
    print("=" * len(title))
    line = "  ".join(str(h).ljust(w) for h, w in zip(headers, widths, strict=True))
    print(line)
    print("-" * len(line))
    for row in figures.rows:
        cells = [row[0].ljust(widths[0])] + [
            str(c).rjust(w) for c, w in zip(row[1:5], widths[1:5], strict=True)
        ]
        print("  ".join(cells) + "  " + row[5])
    for note in figures.notes:
        print(f"  * {note}")
    print(
        f"  ({elapsed:.0f} s for this database; load average now {os.getloadavg()[0]:.1f}: "
        "other processes on these 2 cores lower every req/s figure; server CPU per request "
        "is the steadier measure)"
    )


def summarize_profile(profile_dir: Path) -> None:
    import pstats

    files = sorted(str(p) for p in profile_dir.glob("worker-*.prof"))
    if not files:
        print(f"  no profile files in {profile_dir}")
        return
    stats = pstats.Stats(*files)
    stats.strip_dirs()
    print(f"\n--- cProfile of all requests, {profile_dir} (top by own time) ---")
    stats.sort_stats("tottime").print_stats(30)
    print("--- same, by cumulative time ---")
    stats.sort_stats("cumulative").print_stats(40)
