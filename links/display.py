"""The vessel page's "Links" block: what each transport carried and cost (fleet/admin.py)."""

from __future__ import annotations

import datetime as dt

from django.utils import timezone
from django.utils.html import format_html, format_html_join
from django.utils.safestring import SafeString

from links.models import Transport
from links.selectors import WEEK_DAYS, LinkUsage, Totals, link_usage


def fmt_age(at: dt.datetime | None, now: dt.datetime) -> str:
    """How long ago, in the largest unit that fits ("never" when not heard)."""
    if at is None:
        return "never"
    s = max(0, int((now - at).total_seconds()))
    for unit, size in (("d", 86400), ("h", 3600), ("min", 60)):
        if s >= size:
            return f"{s // size} {unit} ago"
    return f"{s} s ago"


def fmt_bytes(n: int) -> str:
    if n < 10_000:
        return f"{n} B"
    if n < 10_000_000:
        return f"{n / 1000:.1f} kB"
    return f"{n / 1e6:.1f} MB"


def _totals(t: Totals) -> tuple[str, str, str]:
    return (
        f"{t.messages_in} in / {t.messages_out} out",
        f"{fmt_bytes(t.bytes_in)} in / {fmt_bytes(t.bytes_out)} out",
        str(t.credits),
    )


def _per_fix(t: Totals) -> str:
    per = t.bytes_per_fix
    if per is None:
        return "–"
    size = f"{per:.1f} B" if per < 100 else f"{per:.0f} B"  # 4.2 B, 384 B: no false decimals
    return f"{size} ({t.fixes_in} {'fix' if t.fixes_in == 1 else 'fixes'})"


def _row(u: LinkUsage, now: dt.datetime) -> tuple[str, ...]:
    return (Transport(u.transport).label, fmt_age(u.last_contact_at, now),
            *_totals(u.today), *_totals(u.week), _per_fix(u.week))  # fmt: skip


def links_html(vessel_id: int, now: dt.datetime | None = None) -> SafeString:
    """A table: per transport, last contact, today's and the week's messages / bytes /
    credits (SBD credits, SMS segments), and the bytes each fix cost over the week."""
    now = now or timezone.now()
    rows = format_html_join(
        "",
        '<tr class="link-{}"><td>{}</td><td class="nowrap">{}</td><td>{}</td><td>{}</td>'
        "<td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
        ((u.transport, *_row(u, now)) for u in link_usage(vessel_id=vessel_id, now=now)),
    )
    return format_html(
        '<table class="links"><tr><th>link</th><th>last contact</th>'
        "<th>messages today</th><th>bytes today</th><th>credits today</th>"
        "<th>messages {} d</th><th>bytes {} d</th><th>credits {} d</th>"
        "<th>bytes per fix ({} d)</th></tr>{}</table>"
        "<p class=\"help\">Credits: Iridium SBD credits (50 bytes each), SMS segments. Days are "
        "UTC; today is the current UTC day. HTTP counts reach this page within LINK_FLUSH_S "
        "seconds.</p>",
        WEEK_DAYS, WEEK_DAYS, WEEK_DAYS, WEEK_DAYS, rows,
    )  # fmt: skip
