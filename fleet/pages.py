from __future__ import annotations

from django.shortcuts import redirect
from django.urls import path

from fleet import views


def home(request):  # noqa: ANN001, ANN201
    # The admin is the operator's home, with the fleet map on its index page.
    return redirect("admin:index")


urlpatterns = [
    path("", home, name="home"),
    path("fleet/vessels/<slug:slug>/track/", views.track_page, name="fleet-track"),
]
