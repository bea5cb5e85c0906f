"""Which command actions the fleet map offers for a vessel kind, read from the command catalog.

Pure (the catalog is pure): no ORM, no request. The map offers the everyday navigation and
light commands (issue 9 §4); every other kind stays in the admin's command form. How an
action takes its parameters follows from the catalog's own parameter list:
``point`` (lat and lon: click the map), ``bearing`` (click the map, the bearing from the
vessel; or type one, within the action's ``min`` and ``max``), ``choice`` (one button per
allowed value) or nothing (one button).
"""

from __future__ import annotations

from typing import Any

from commands.catalog import kinds_for

# The map's actions, in the order the panel shows them.
MAP_KINDS = ("move_to", "fhead", "hold", "resume", "return_home", "light")


def map_actions(vessel_kind: str) -> list[dict[str, Any]]:
    """The map actions for one vessel kind: [{kind, label, input, param?, choices?}]."""
    offered = {k.name: k for k in kinds_for(vessel_kind) if k.name in MAP_KINDS}
    actions = []
    for name in MAP_KINDS:
        kind = offered.get(name)
        if kind is None:
            continue
        names = [p.name for p in kind.params]
        action: dict[str, Any] = {"kind": kind.name, "label": kind.label, "input": "none"}
        if names == ["lat", "lon"]:
            action["input"] = "point"
        elif names == ["bearing"]:
            # The catalog's range, so the typed heading is checked as the server will.
            bearing = kind.params[0]
            action.update(
                input="bearing", param="bearing", min=bearing.minimum, max=bearing.maximum
            )
        elif len(kind.params) == 1 and kind.params[0].kind == "choice":
            param = kind.params[0]
            action.update(input="choice", param=param.name, choices=list(param.choices))
        elif names:
            continue  # parameters the map cannot pick: the admin form's job
        actions.append(action)
    return actions
