from __future__ import annotations

from django.db.models import QuerySet
from django.shortcuts import get_object_or_404

from vessels.models import Vessel


def vessel_list() -> QuerySet[Vessel]:
    return Vessel.objects.all().order_by("name")


def vessel_by_slug(slug: str) -> Vessel:
    return get_object_or_404(Vessel, slug=slug)
