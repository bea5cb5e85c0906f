"""The fleet map's open alerts and fences (issue 19): a red badge per vessel with open alerts, in
the list too, the vessel's alerts in its panel with an Acknowledge button, and the fences drawn
on the map. Reads only; acknowledging is the alerts API's (`POST /api/v1/alerts/<id>/ack/`).

Open alerts are polled as often as the fleet (they are what an operator must see at once), from
the partial index of active alerts (alerts.models.Alert ``alert_active_by_vessel``); fences
change seldom and ride with the trails (fleet.console_api)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from alerts.models import ACTIVE_STATES, Alert
from vessels.models import Fence, Vessel


def alert_entry(alert: Alert) -> dict[str, Any]:
    acknowledged = alert.acknowledged_at
    return {
        "id": alert.pk,
        "vessel": alert.vessel.slug,
        "rule": alert.rule.name,
        "kind": alert.kind,
        "state": alert.state,
        "opened_at": alert.opened_at.isoformat(),
        "acknowledged_at": acknowledged.isoformat() if acknowledged else None,
        "acknowledged_by": alert.acknowledged_by,
        "detail": alert.detail,
        "value": alert.value,
    }


def active_alerts(vessels: Iterable[Vessel]) -> list[dict[str, Any]]:
    """The open and acknowledged alerts of ``vessels``, newest first. One query."""
    ids = [v.pk for v in vessels]
    rows = (
        Alert.objects.filter(vessel_id__in=ids, state__in=[s.value for s in ACTIVE_STATES])
        .select_related("vessel", "rule")
        .only(
            "id", "vessel__slug", "rule__name", "kind", "state", "opened_at", "acknowledged_at",
            "acknowledged_by", "detail", "value",
        )
        .order_by("-opened_at", "-id")
    )  # fmt: skip
    return [alert_entry(a) for a in rows]


def fence_entries(vessels: Iterable[Vessel]) -> list[dict[str, Any]]:
    """The fences of ``vessels`` and those every vessel keeps, as the map draws them."""
    ids = [v.pk for v in vessels]
    fences = Fence.objects.filter(vessel_id__in=ids) | Fence.objects.filter(vessel__isnull=True)
    return [
        {
            "id": f.pk,
            "name": f.name,
            "vessel": f.vessel.slug if f.vessel_id else None,
            "inclusion": f.inclusion,
            "geometry": f.geometry,
            "radius_m": f.radius_m,
        }
        for f in fences.select_related("vessel").order_by("name", "pk")
    ]
