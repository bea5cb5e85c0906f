"""The operator's map pages (HTML). Thin: the data comes from the JSON endpoints the pages'
scripts call; the views check rights and hand the page its frame (fleet.maps)."""

from __future__ import annotations

from django.contrib import admin
from django.contrib.auth.decorators import login_required
from django.core.exceptions import PermissionDenied
from django.http import HttpRequest, HttpResponse
from django.shortcuts import render

from fleet.maps import can_view_track, track_page_config
from vessels.selectors import vessel_by_slug

# The range the track page opens with: the vessel's last run of reports ("last", at most
# LAST_STRETCH_MAX long, fleet.maps.last_stretch_range); 24 h back from now for a vessel
# with no fixes. The operator may pick 6 h, 24 h, 7 days or a custom one.
DEFAULT_RANGE = "last"
NO_FIXES_RANGE = "24h"


@login_required
def track_page(request: HttpRequest, slug: str) -> HttpResponse:
    """One vessel's track for a time range, its nearest fix on click, and its sensor plots."""
    # Rights first: an operator without them gets the same 403 for any slug, real or not.
    if not (request.user.is_staff and can_view_track(request.user)):
        raise PermissionDenied
    vessel = vessel_by_slug(slug)
    config = track_page_config(request, vessel)
    context = {
        **admin.site.each_context(request),
        "title": f"{vessel.name}: track",
        "vessel": vessel,
        "page_config": config,
        "default_range": DEFAULT_RANGE if config["lastStretch"] else NO_FIXES_RANGE,
    }
    return render(request, "fleet/track.html", context)
