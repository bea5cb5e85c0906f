from __future__ import annotations

from django.shortcuts import redirect
from django.urls import path


def home(request):  # noqa: ANN001, ANN201
    # The admin is the operator's home; the fleet map pages come with their own issue.
    return redirect("admin:index")


urlpatterns = [path("", home, name="home")]
