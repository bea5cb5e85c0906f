"""Who may call what: boats (a vessel key) and operators (Django model permissions)."""

from __future__ import annotations

from typing import Any

from rest_framework.permissions import BasePermission, DjangoModelPermissions

from vessels.auth import BoatPrincipal


class IsBoat(BasePermission):
    """Only a request authenticated with a vessel key; operators use the operator API."""

    message = "A vessel key is required (Authorization: Api-Key <key>)."

    def has_permission(self, request: Any, view: Any) -> bool:
        return isinstance(request.user, BoatPrincipal)


class ModelPermissions(DjangoModelPermissions):
    """Django model permissions, with reads needing the `view` permission too.

    DRF's default lets any logged-in user read; an operator without rights to a model
    must not see it either.
    """

    perms_map = {
        **DjangoModelPermissions.perms_map,
        "GET": ["%(app_label)s.view_%(model_name)s"],
        "HEAD": ["%(app_label)s.view_%(model_name)s"],
        "OPTIONS": ["%(app_label)s.view_%(model_name)s"],
    }

    def _queryset(self, view: Any) -> Any:
        # Views scoped by URL (a vessel's fixes) set `queryset` for this check: DRF would
        # otherwise call get_queryset() first, and a 404-versus-403 would tell an operator
        # without rights which vessels exist.
        if getattr(view, "queryset", None) is not None:
            return view.queryset
        return super()._queryset(view)


class ChangeModelPermissions(ModelPermissions):
    """For POST actions that change an existing object (cancel), not create one."""

    perms_map = {**ModelPermissions.perms_map, "POST": ["%(app_label)s.change_%(model_name)s"]}


class CanViewVessels(BasePermission):
    """For endpoints under /vessels/<slug>/: naming a vessel needs the right to see vessels.

    Checked before the slug is looked up, so an operator allowed to read commands (or fixes)
    but not vessels gets the same 403 for a slug that exists and one that does not.
    """

    def has_permission(self, request: Any, view: Any) -> bool:
        return bool(request.user and request.user.has_perm("vessels.view_vessel"))
