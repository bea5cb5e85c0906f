"""``{% fleet_map %}``: the fleet map on the admin index, the operator's home (issue 9 §1)."""

from __future__ import annotations

from typing import Any

from django import template

from fleet.maps import can_view_fleet, fleet_map_config

register = template.Library()


@register.inclusion_tag("fleet/fleet_map.html", takes_context=True)
def fleet_map(context: template.Context) -> dict[str, Any]:
    request = context["request"]
    if not can_view_fleet(request.user):
        return {"show": False}
    return {
        "show": True,
        "page_config": fleet_map_config(request),
        "map_config": context.get("map_config", {}),
    }
