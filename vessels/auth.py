"""Boat authentication: one vessel key per request, in DRF's own terms (STYLE §14)."""

from __future__ import annotations

import base64

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


class VesselKeyAuthentication(BaseAuthentication):
    """`Authorization: Api-Key <key>` → (BoatPrincipal, VesselKey)."""

    def authenticate(self, request: Request) -> tuple[BoatPrincipal, VesselKey] | None:
        header = request.META.get("HTTP_AUTHORIZATION", "")
        scheme, _, raw = header.partition(" ")
        if scheme.lower() != SCHEME.lower():
            return None
        key = key_lookup(raw.strip())
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
