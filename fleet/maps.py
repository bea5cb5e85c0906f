"""What the map pages show, gathered on the server: sensor channel labels and units, the
command actions the operator may use, the endpoint URLs the page's scripts call.

Reads only (no writes): the pages' data comes from the JSON endpoints, this is their frame.
"""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.conf import settings
from django.contrib.auth.base_user import AbstractBaseUser
from django.http import HttpRequest
from django.middleware.csrf import get_token
from django.urls import reverse

from edge_client.contract.status import OPEN, UNFINISHED, Status
from fleet.map_actions import map_actions
from telemetry.api.maps import TRACK_DEFAULT_POINTS
from telemetry.models import SensorChannel
from telemetry.track import latest_stretch
from vessels.display import BATTERY, state_channels_config
from vessels.models import OVERDUE_PERIODS, Vessel, VesselKind

SLUG = "__slug__"  # placeholder the scripts replace with a vessel's slug
UID = "__uid__"
ALERT_ID = "__id__"
# The fleet map's side panel lists this many of the vessel's newest commands.
PANEL_COMMANDS = 8
# The track page opens on the vessel's last run of reports, this long at most and at least.
LAST_STRETCH_MAX = dt.timedelta(hours=24)
LAST_STRETCH_MIN = dt.timedelta(minutes=10)


def sensor_channels() -> dict[str, dict[str, Any]]:
    """{key: {label, unit, min, max}} for every SensorChannel (a few dozen rows at most)."""
    return {
        c.key: {"label": c.label, "unit": c.unit, "min": c.minimum, "max": c.maximum}
        for c in SensorChannel.objects.all()
    }


def page_channels() -> dict[str, dict[str, Any]]:
    """The channels a page labels its readings with: battery, the state channels (mode, armed:
    named values, plotted as steps) and every SensorChannel. A SensorChannel row for a state
    channel relabels it; its named values stay."""
    states, sensors = state_channels_config(), sensor_channels()
    channels = {"battery_v": BATTERY, **states, **sensors}
    for key in states.keys() & sensors.keys():
        channels[key] = {**states[key], **sensors[key]}
    return channels


def _iso(when: dt.datetime) -> str:
    return when.astimezone(dt.UTC).isoformat().replace("+00:00", "Z")


def can_view_fleet(user: AbstractBaseUser) -> bool:
    return user.is_active and user.has_perm("vessels.view_vessel")


def can_view_track(user: AbstractBaseUser) -> bool:
    return can_view_fleet(user) and user.has_perm("telemetry.view_fix")


def can_view_overlays(user: AbstractBaseUser) -> bool:
    return can_view_fleet(user) and (
        user.has_perm("telemetry.view_fix") or user.has_perm("commands.view_command")
    )


def can_view_alerts(user: AbstractBaseUser) -> bool:
    return can_view_fleet(user) and user.has_perm("alerts.view_alert")


def trail_choices(default: int) -> list[int]:
    """The trail lengths the map offers (minutes; 0 = none), the configured one among them."""
    return sorted({0, 15, 60, 180, 720, default})


def _vessel_url(name: str) -> str:
    return reverse(name, kwargs={"slug": SLUG})


def fleet_map_config(request: HttpRequest) -> dict[str, Any]:
    """The fleet map's page config (json_script): endpoints, rights, channels, actions."""
    user = request.user
    can_command = user.has_perm("commands.add_command")
    return {
        "fleetUrl": reverse("fleet"),
        "commandsUrl": _vessel_url("vessel-commands"),
        "cancelUrl": reverse("command-cancel", kwargs={"uid": UID}),
        "trackUrl": _vessel_url("fleet-track") if can_view_track(user) else "",
        "pollS": settings.FLEET_MAP_POLL_S,
        # Trails and running missions (fleet.console): only for who may see fixes or commands.
        "overlaysUrl": reverse("fleet-overlays") if can_view_overlays(user) else "",
        "trailMinutes": settings.FLEET_MAP_TRAIL_MINUTES,
        "trailChoices": trail_choices(settings.FLEET_MAP_TRAIL_MINUTES),
        "trailRefreshS": settings.FLEET_MAP_TRAIL_REFRESH_S,
        "overduePeriods": OVERDUE_PERIODS,
        "panelCommands": PANEL_COMMANDS,
        "canCommand": can_command,
        "canCancel": user.has_perm("commands.change_command"),
        "canViewCommands": user.has_perm("commands.view_command"),
        # Open alerts (issue 19), polled with the fleet: badges, the panel's list, Acknowledge.
        "alertsUrl": reverse("fleet-alerts") if can_view_alerts(user) else "",
        "ackUrl": reverse("alert-ack", kwargs={"pk": 987654321}).replace("987654321", ALERT_ID),
        "canAck": user.has_perm("alerts.change_alert"),
        "csrfToken": get_token(request),
        "channels": page_channels(),
        # Status names from the contract, not a copy in the script: an unfinished command is
        # drawn as open (its move_to target on the map); a cancel is offered while it is OPEN.
        "statuses": {
            "unfinished": [s.value for s in Status if s in UNFINISHED],
            "cancellable": [s.value for s in OPEN],
        },
        # Without the add permission, no buttons: the API would answer 403 anyway.
        "actions": {kind: map_actions(kind) if can_command else [] for kind in VesselKind.values},
    }


def last_stretch_range(vessel: Vessel) -> tuple[dt.datetime, dt.datetime] | None:
    """The track page's first range: the vessel's last run of reports (up to
    LAST_STRETCH_MAX, ending at its newest fix) in whole minutes, as the page's inputs show
    them, and at least LAST_STRETCH_MIN; None when it has no fixes."""
    stretch = latest_stretch(
        vessel=vessel, max_span=LAST_STRETCH_MAX, max_points=TRACK_DEFAULT_POINTS
    )
    if stretch is None:
        return None
    first, last = stretch
    minute = dt.timedelta(minutes=1)
    start = first.replace(second=0, microsecond=0)
    # The minute after the newest fix: the range is half-open, so the fix stays in it.
    end = last.replace(second=0, microsecond=0) + minute
    return min(start, end - LAST_STRETCH_MIN), end


def track_page_config(request: HttpRequest, vessel: Vessel) -> dict[str, Any]:
    """The track page's config: the vessel's data endpoints, the channel labels and its
    last run of reports (the page's first range)."""
    slug = vessel.slug

    def url(name: str) -> str:
        return reverse(name, kwargs={"slug": slug})

    stretch = last_stretch_range(vessel)
    return {
        "slug": slug,
        "lastStretch": stretch and {"from": _iso(stretch[0]), "to": _iso(stretch[1])},
        "trackUrl": url("vessel-track"),
        "nearestUrl": url("vessel-fix-nearest"),
        "seriesUrl": url("vessel-series"),
        "exportUrl": url("vessel-track-export"),
        "pageUrl": url("fleet-track"),
        "channels": page_channels(),
    }
