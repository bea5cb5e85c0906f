"""`manage.py issue_key` refuses bad input with a clear message, not a traceback."""

from __future__ import annotations

import io

import pytest
from django.core.management import CommandError, call_command

from vessels.models import Vessel, VesselKey


@pytest.mark.django_db
def test_an_overlong_label_is_a_clear_error_and_issues_nothing(vessel_a: Vessel) -> None:
    out = io.StringIO()
    with pytest.raises(CommandError, match="label"):
        call_command("issue_key", "spab", "--label", "x" * 101, stdout=out, stderr=io.StringIO())
    assert out.getvalue() == ""
    assert not VesselKey.objects.exists()
