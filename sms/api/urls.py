"""SMS endpoints for boats under /api/v1/: the vessel's authorised numbers, its SMS log upload."""

from __future__ import annotations

from django.urls import path

from sms.api import boat

urlpatterns = [
    path("boat/numbers/", boat.NumbersView.as_view(), name="boat-numbers"),
    path("boat/sms/", boat.SmsLogView.as_view(), name="boat-sms"),
]
