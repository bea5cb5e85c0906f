"""Boat authentication: one vessel key per request, in DRF's own terms (STYLE §14)."""

from __future__ import annotations

import base64
import time

from django.http import HttpRequest
from django.utils import timezone
from drf_spectacular.extensions import OpenApiAuthenticationExtension
from rest_framework.authentication import BaseAuthentication
from rest_framework.exceptions import AuthenticationFailed
from rest_framework.request import Request

from vessels.keys import hash_key
from vessels.models import Vessel, VesselKey
from vessels.selectors import vessel_key_by_hash
from vessels.services import vessel_key_touch

SCHEME = "Api-Key"


class BoatPrincipal:
    """The `request.user` of a boat request: authenticated as a vessel, never as an operator."""

    is_authenticated = True
    is_active = True
    is_staff = False
    is_superuser = False
    is_anonymous = False

    def __init__(self, vessel: Vessel) -> None:
        self.vessel = vessel

    def __str__(self) -> str:
        return f"vessel:{self.vessel.slug}"

    def has_perm(self, perm: str, obj: object = None) -> bool:
        return False


def key_lookup(raw_key: str) -> VesselKey:
    """The active key matching ``raw_key``, with its vessel; raises AuthenticationFailed."""
    if not raw_key or len(raw_key) > 200:
        raise AuthenticationFailed("Invalid vessel key.")
    key = vessel_key_by_hash(hash_key(raw_key))
    if key is None:
        raise AuthenticationFailed("Invalid vessel key.")
    if key.revoked_at is not None:
        raise AuthenticationFailed("This vessel key has been revoked.")
    if not key.vessel.active:
        raise AuthenticationFailed("This vessel is not active.")
    vessel_key_touch(key=key, now=timezone.now())
    return key


# Keys this process looked up lately, by hash: (when, key with its vessel). Only for a write that
# carries the key's own check (telemetry's single post: vessels.selectors.key_valid_sql), so a
# revoked key still stops at once; the cache spares that request the key's SELECT, the boat's
# everyday request its second statement (issue 17 item 8). An entry lives KEY_RECENT_S at most
# (a renamed vessel's slug, in log lines, is that late), and the whole cache is dropped when
# full.
KEY_RECENT_S = 60.0
KEY_RECENT_MAX = 10_000
_recent: dict[str, tuple[float, VesselKey]] = {}


def key_lookup_recent(raw_key: str) -> VesselKey:
    """:func:`key_lookup`, from this process's recent lookups when it has the key: only for a
    caller whose writes check the key (key_valid_sql) and that calls :func:`key_forget` and
    looks again when they find it no longer works."""
    if not raw_key or len(raw_key) > 200:
        raise AuthenticationFailed("Invalid vessel key.")
    key_hash = hash_key(raw_key)
    found = _recent.get(key_hash)
    now = time.monotonic()
    if found is not None and now - found[0] < KEY_RECENT_S:
        key = found[1]
        vessel_key_touch(key=key, now=timezone.now())
        return key
    key = key_lookup(raw_key)
    if len(_recent) >= KEY_RECENT_MAX:
        _recent.clear()
    _recent[key_hash] = (now, key)
    return key


def key_is_recent(raw_key: str) -> bool:
    """Whether :func:`key_lookup_recent` would answer ``raw_key`` from the recent lookups
    (no query, nothing refused); it looks only, changing nothing."""
    if not raw_key or len(raw_key) > 200:
        return False
    found = _recent.get(hash_key(raw_key))
    return found is not None and time.monotonic() - found[0] < KEY_RECENT_S


def key_forget(raw_key: str) -> None:
    """Drop ``raw_key`` from the recent lookups (its write found it no longer works)."""
    _recent.pop(hash_key(raw_key), None)


def raw_key(request: HttpRequest | Request) -> str:
    """The key of an `Authorization: Api-Key <key>` header, or "" when there is none."""
    scheme, _, raw = request.META.get("HTTP_AUTHORIZATION", "").partition(" ")
    return raw.strip() if scheme.lower() == SCHEME.lower() else ""


def key_recheck(request: Request) -> None:
    """Look the request's key up afresh: AuthenticationFailed if it no longer works.

    For any error a view with ``keys_checked_by_writes`` answers (a bad body, a refused write):
    a key revoked since its recent lookup is a 401 first, as it is when the lookup is fresh."""
    raw = raw_key(request)
    if raw:
        key_forget(raw)
        key_lookup(raw)


class VesselKeyAuthentication(BaseAuthentication):
    """`Authorization: Api-Key <key>` → (BoatPrincipal, VesselKey).

    A view whose writes check the key themselves (``keys_checked_by_writes = True``, and
    errors through :func:`key_recheck`) is given it from the recent lookups."""

    def authenticate(self, request: Request) -> tuple[BoatPrincipal, VesselKey] | None:
        header = request.META.get("HTTP_AUTHORIZATION", "")
        scheme, _, raw = header.partition(" ")
        if scheme.lower() != SCHEME.lower():
            return None
        view = (getattr(request, "parser_context", None) or {}).get("view")
        lookup = key_lookup_recent if getattr(view, "keys_checked_by_writes", False) else key_lookup
        key = lookup(raw.strip())
        return BoatPrincipal(key.vessel), key

    def authenticate_header(self, request: Request) -> str:
        return SCHEME


class LegacyKeyAuthentication(VesselKeyAuthentication):
    """The legacy SPAB endpoints also take HTTP Basic (user = slug, password = key), an
    `Api-Key` header, or `?key=` (the F2414 modem could not do Basic auth; docs/api.md)."""

    def authenticate(self, request: Request) -> tuple[BoatPrincipal, VesselKey] | None:
        found = super().authenticate(request)
        if found is not None:
            return found
        slug, raw = _from_basic(request._request)
        raw = raw or request._request.META.get("HTTP_API_KEY") or request.query_params.get("key")
        if not raw:
            return None
        key = key_lookup(raw)
        if slug and slug != key.vessel.slug:
            raise AuthenticationFailed("The key does not belong to that vessel.")
        return BoatPrincipal(key.vessel), key

    def authenticate_header(self, request: Request) -> str:
        return 'Basic realm="shoreside"'


def _from_basic(request: HttpRequest) -> tuple[str, str]:
    """(slug, key) from HTTP Basic credentials, or ("", "") when there are none."""
    scheme, _, encoded = request.META.get("HTTP_AUTHORIZATION", "").partition(" ")
    if scheme.lower() != "basic":
        return "", ""
    try:
        slug, _, password = base64.b64decode(encoded, validate=True).decode().partition(":")
    except ValueError:  # binascii.Error, UnicodeDecodeError, or non-ASCII header text
        raise AuthenticationFailed("Malformed Basic credentials.") from None
    return slug, password


class VesselKeyScheme(OpenApiAuthenticationExtension):
    """Describes `Authorization: Api-Key <key>` in the OpenAPI schema, so the docs page can
    try boat endpoints and drf-spectacular stops warning it cannot resolve the class."""

    target_class = VesselKeyAuthentication
    name = "vesselKey"

    def get_security_definition(self, auto_schema: object) -> dict[str, str]:
        return {
            "type": "apiKey",
            "in": "header",
            "name": "Authorization",
            "description": "A vessel key: `Api-Key <key>`.",
        }
