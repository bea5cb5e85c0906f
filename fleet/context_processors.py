"""What every map page needs from the settings, read per request (tests and a changed
environment take effect without re-importing django-leaflet, which reads its own config once)."""

from __future__ import annotations

from typing import Any

from django.conf import settings
from django.http import HttpRequest
from django.templatetags.static import static

COASTLINE_INDEX = "vessels/vendor/naturalearth/index.json"


def maps(request: HttpRequest) -> dict[str, Any]:
    leaflet = getattr(settings, "LEAFLET_CONFIG", {})
    return {
        "map_config": {
            # Empty: no tile layer (docs/operating.md: the site works at sea, with no tile server).
            "tiles_url": settings.MAP_TILES_URL or "",
            "attribution": settings.MAP_TILES_ATTRIBUTION,
            "center": list(leaflet.get("DEFAULT_CENTER", (0.0, 0.0))),
            "zoom": leaflet.get("DEFAULT_ZOOM", 9),
            # The offline coastline's index (vessels/static/vessels/vendor/naturalearth/): drawn
            # when there are no tiles or they fail; its cells are fetched from beside it.
            "coastline": static(COASTLINE_INDEX),
        }
    }
