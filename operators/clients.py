"""The client's address, believing X-Forwarded-For only from the proxies in TRUSTED_PROXIES.

Anyone can send an X-Forwarded-For header; only a proxy we run appends a true entry to it.
So the header counts only when the request came from a trusted proxy, and then only the
entries that proxies we trust appended: reading from the right, the first address that is not
one of them is the client. A request straight from the internet is its REMOTE_ADDR.
"""

from __future__ import annotations

import ipaddress
from collections.abc import Sequence
from functools import lru_cache

from django.conf import settings
from django.http import HttpRequest

Network = ipaddress.IPv4Network | ipaddress.IPv6Network


@lru_cache(maxsize=8)
def _networks(trusted: tuple[str, ...]) -> tuple[Network, ...]:
    return tuple(ipaddress.ip_network(value, strict=False) for value in trusted)


def _trusted(address: str, networks: Sequence[Network]) -> bool:
    try:
        ip = ipaddress.ip_address(address.strip().strip("[]"))
    except ValueError:
        return False
    return any(ip in network for network in networks)


def client_address_from(remote_addr: str, forwarded_for: str, trusted: Sequence[str]) -> str:
    """The client's address given the peer's address, its X-Forwarded-For and the trusted
    proxies (addresses or networks). Pure, so the rule is tested without requests."""
    networks = _networks(tuple(trusted))
    if not _trusted(remote_addr, networks):
        return remote_addr
    hops = [hop.strip() for hop in forwarded_for.split(",") if hop.strip()]
    for hop in reversed(hops):
        if not _trusted(hop, networks):
            return hop
    # Only proxies in the chain (or no header): the first of them stands for the client.
    return hops[0] if hops else remote_addr


def client_address(request: HttpRequest) -> str:
    """The address failed logins are counted by (and anything else keyed on the client)."""
    return client_address_from(
        request.META.get("REMOTE_ADDR", ""),
        request.META.get("HTTP_X_FORWARDED_FOR", ""),
        settings.TRUSTED_PROXIES,
    )
