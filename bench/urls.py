"""Bench-only URLs: the whole site (fleet.urls) plus the baselines of bench.baseline."""

from django.urls import include, path

from bench import baseline

urlpatterns = [
    path("bench/hello/", baseline.hello, name="bench-hello"),
    path("bench/drf/telemetry/", baseline.DrfTelemetryView.as_view(), name="bench-drf-telemetry"),
    path("bench/drf/commands/", baseline.drf_commands, name="bench-drf-commands"),
    path("", include("fleet.urls")),
]
