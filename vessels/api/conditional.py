"""Conditional GETs for the polled endpoints (the boat's command poll and numbers, the fleet
map): one reading of ``If-None-Match``, on Django's own parser."""

from __future__ import annotations

from django.utils.http import parse_etags


def etag_matches(if_none_match: str | None, etag: str) -> bool:
    """RFC 9110 §13.1.2: If-None-Match may list several tags and compares weakly, so a
    proxy that weakened our tag (nginx does when it gzips) still earns the client its 304."""
    if not if_none_match:
        return False
    if if_none_match == etag:  # the common case, without parsing
        return True
    return any(tag.removeprefix("W/") == etag for tag in parse_etags(if_none_match))
