"""Static files after collectstatic (issue 18 §1): hashed names, gzip copies and a year's cache
for the map pages' scripts and the offline coastline; plain names where it has not run."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from django.contrib.auth.models import User
from django.core.management import call_command
from django.templatetags.static import static

from tests.fleet.test_pages import client_for, page_config

YEAR = "max-age=315360000, public, immutable"


def body(response) -> bytes:
    return b"".join(response.streaming_content)


def test_without_collectstatic_a_page_gets_the_plain_names() -> None:
    assert static("vessels/mapkit.js") == "/static/vessels/mapkit.js"


@pytest.mark.slow
@pytest.mark.django_db
def test_after_collectstatic_map_assets_have_hashed_names_cached_for_a_year(
    settings, tmp_path: Path, operator_user: User
) -> None:
    settings.STATIC_ROOT = tmp_path
    settings.WHITENOISE_USE_FINDERS = False
    call_command("collectstatic", "--noinput", verbosity=0)
    client = client_for(operator_user)  # a new client: WhiteNoise reads the new STATIC_ROOT
    html = client.get("/admin/").content.decode()

    mapkit = re.search(r'src="(/static/vessels/mapkit\.[0-9a-f]{12}\.js)"', html)
    assert mapkit, "the fleet map's script is not under its hashed name"
    response = client.get(mapkit.group(1), HTTP_ACCEPT_ENCODING="gzip")
    assert response.status_code == 200 and response["Content-Encoding"] == "gzip"
    assert response["Cache-Control"] == YEAR

    index_url = page_config(html, "map-config")["coastline"]
    assert re.fullmatch(r"/static/vessels/vendor/naturalearth/index\.[0-9a-f]{12}\.json", index_url)
    response = client.get(index_url)
    assert response["Cache-Control"] == YEAR
    index = json.loads(body(response))
    # The cells, fetched from beside the index under their own names, are cached for a year too.
    cell = f"{index_url.rsplit('/', 1)[0]}/{index['base']}10m/s35e115.json"
    response = client.get(cell, HTTP_ACCEPT_ENCODING="gzip")
    assert response.status_code == 200 and response["Content-Encoding"] == "gzip"
    assert response["Cache-Control"] == YEAR
    # A name with no hash in it may change: a short cache.
    response = client.get("/static/vessels/mapkit.js")
    assert response.status_code == 200 and "immutable" not in response["Cache-Control"]
