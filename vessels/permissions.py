from __future__ import annotations

from typing import Any

from rest_framework.permissions import BasePermission

from vessels.auth import BoatPrincipal


class IsBoat(BasePermission):
    """Only a request authenticated with a vessel key; operators use the operator API."""

    message = "A vessel key is required (Authorization: Api-Key <key>)."

    def has_permission(self, request: Any, view: Any) -> bool:
        return isinstance(request.user, BoatPrincipal)
