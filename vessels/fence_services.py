"""Writes for fences: create, change, delete, import from a file. The admin (map drawing), the
operator API and the alerts' fence rules all come here; each write leaves an audit entry in
its own transaction (audit.services.audit_record).

Sending a fence to a vessel queues a command, which the commands app owns (`fence_send`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from django.db import transaction

from audit.services import audit_changes, audit_record, audit_snapshot
from vessels.missionfiles import fences as fencefiles
from vessels.models import Fence, Vessel

# What an update may change (the rest is the row's own bookkeeping).
FENCE_FIELDS = ("name", "vessel", "inclusion", "geometry", "radius_m", "notes")


def _audit(fence: Fence, action: str, *, by: str, via: str, ip: str | None, **detail: Any) -> None:
    audit_record(
        action=action,
        actor=by,
        via=via,
        ip=ip,
        subject_type="fence",
        subject_id=fence.pk,
        subject=f"{fence.name} ({'inclusion' if fence.inclusion else 'exclusion'}, {fence.shape})",
        vessel=fence.vessel.slug if fence.vessel_id else "",
        detail=detail,
    )


@transaction.atomic
def fence_create(
    *,
    name: str,
    geometry: Any,
    radius_m: float | None = None,
    inclusion: bool = True,
    vessel: Vessel | None = None,
    notes: str = "",
    by: str = "",
    via: str = "",
    ip: str | None = None,
) -> Fence:
    """A new fence, its geometry checked and normalised (vessels.fences.clean, via the
    model's clean()); a bad one raises ValidationError naming the field."""
    fence = Fence(
        name=name,
        geometry=geometry,
        radius_m=radius_m,
        inclusion=inclusion,
        vessel=vessel,
        notes=notes,
    )
    fence.full_clean()
    fence.save()
    _audit(fence, "fence.created", by=by, via=via, ip=ip, geometry=fence.geometry,
           radius_m=fence.radius_m)  # fmt: skip
    return fence


@transaction.atomic
def fence_update(
    *, fence: Fence, fields: Mapping[str, Any], by: str = "", via: str = "", ip: str | None = None
) -> Fence:
    """Change ``fields`` of ``fence`` (a subset of FENCE_FIELDS). Changing a circle into a
    polygon clears its radius unless one is given."""
    unknown = set(fields) - set(FENCE_FIELDS)
    if unknown:
        raise ValueError(f"fence_update cannot change {', '.join(sorted(unknown))}")
    before = audit_snapshot(fence, fields)
    for name, value in fields.items():
        setattr(fence, name, value)
    geometry = fence.geometry if isinstance(fence.geometry, dict) else {}
    if "geometry" in fields and "radius_m" not in fields and geometry.get("type") == "Polygon":
        fence.radius_m = None
    fence.full_clean()
    fence.save()
    changed = audit_changes(before, audit_snapshot(fence, fields))
    if changed:
        _audit(fence, "fence.changed", by=by, via=via, ip=ip, changed=changed)
    return fence


@transaction.atomic
def fence_delete(*, fence: Fence, by: str = "", via: str = "", ip: str | None = None) -> None:
    """Delete a fence, and with it the alert rules that watch it (AlertRule.fence cascades).
    The audit entry keeps its geometry: a fence deleted is still one that was in force."""
    _audit(fence, "fence.deleted", by=by, via=via, ip=ip, geometry=fence.geometry,
           radius_m=fence.radius_m)  # fmt: skip
    fence.delete()


@transaction.atomic
def fence_import(
    *,
    content: bytes | str,
    format: str | None = None,
    vessel: Vessel | None = None,
    name: str = "",
    filename: str = "",
    by: str = "",
    via: str = "",
    ip: str | None = None,
) -> list[Fence]:
    """Create the fences of a QGC `.plan` (its geoFence section) or a GeoJSON file: all of
    them or, when one is bad, none (FenceFileError lists every problem).

    Each is named by the file when it names it, else ``name`` (default: the file's name)
    and its number in the file."""
    if format is None and filename.lower().endswith(".plan"):
        format = "plan"
    specs = fencefiles.load(content, format=format)
    base = (name or filename.rsplit("/", 1)[-1].rsplit(".", 1)[0] or "Imported fence")[:90]
    created = []
    for n, spec in enumerate(specs, start=1):
        label = spec.name or (base if len(specs) == 1 else f"{base} {n}")
        created.append(
            fence_create(
                name=label[:100],
                geometry=spec.geometry,
                radius_m=spec.radius_m,
                inclusion=spec.inclusion,
                vessel=vessel,
                notes=f"imported from {filename}" if filename else "imported",
                by=by,
                via=via,
                ip=ip,
            )
        )
    return created
