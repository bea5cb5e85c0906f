"""The SBD provider's webhook under /api/v1/ (signed by the provider: no session, no key)."""

from __future__ import annotations

from django.urls import path

from sbd.api import webhook

urlpatterns = [
    path("sbd/rockblock/", webhook.rockblock_delivery, name="sbd-rockblock"),
]
