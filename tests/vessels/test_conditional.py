"""One reading of If-None-Match for every polled endpoint (vessels/api/conditional.py)."""

from __future__ import annotations

import pytest

from vessels.api.conditional import etag_matches

TAG = '"c7.42"'


@pytest.mark.parametrize(
    "header",
    [TAG, f"W/{TAG}", f'"other", {TAG}', f'"a,b", W/{TAG}', f'"x",{TAG}'],
)
def test_a_listed_or_weakened_tag_matches(header: str) -> None:
    assert etag_matches(header, TAG)


@pytest.mark.parametrize("header", [None, "", '"c7.41"', '"c7.42', "c7.42", '"a,"c7.42""'])
def test_anything_else_does_not(header: str | None) -> None:
    assert not etag_matches(header, TAG)
