from __future__ import annotations

from django.db import models
from django.db.models import Q

from vessels.models import Vessel


class Fix(models.Model):
    """One telemetry record. Re-sending a fix is a no-op: (vessel, recorded_at) is unique."""

    vessel = models.ForeignKey(Vessel, on_delete=models.CASCADE, related_name="fixes")
    recorded_at = models.DateTimeField(help_text="Time on the vessel, UTC.")
    received_at = models.DateTimeField()
    lat = models.FloatField()
    lon = models.FloatField()
    heading_deg = models.FloatField(null=True, blank=True)
    speed_mps = models.FloatField(null=True, blank=True)
    battery_v = models.FloatField(null=True, blank=True)
    readings = models.JSONField(default=dict, blank=True)

    class Meta:
        verbose_name_plural = "fixes"
        constraints = [
            # Also the index for (vessel, time range) queries: vessel_id first, then time.
            models.UniqueConstraint(fields=["vessel", "recorded_at"], name="fix_unique_time"),
            models.CheckConstraint(
                condition=Q(lat__gte=-90, lat__lte=90, lon__gte=-180, lon__lte=180),
                name="fix_latlon_range",
            ),
            models.CheckConstraint(
                condition=Q(heading_deg__isnull=True) | Q(heading_deg__gte=0, heading_deg__lt=360),
                name="fix_heading_range",
            ),
            models.CheckConstraint(
                condition=Q(speed_mps__isnull=True) | Q(speed_mps__gte=0),
                name="fix_speed_nonnegative",
            ),
        ]
        # For the admin's newest-first list across all vessels.
        indexes = [models.Index(fields=["-recorded_at"], name="fix_recorded_desc")]

    def __str__(self) -> str:
        return f"{self.vessel_id} @ {self.recorded_at:%Y-%m-%d %H:%M:%S}"


class SensorChannel(models.Model):
    """Display metadata for a reading key (e.g. `water_temp_c`)."""

    key = models.SlugField(max_length=50, unique=True)
    label = models.CharField(max_length=100)
    unit = models.CharField(max_length=20, blank=True)
    minimum = models.FloatField(null=True, blank=True, help_text="Lower bound for plots.")
    maximum = models.FloatField(null=True, blank=True, help_text="Upper bound for plots.")

    class Meta:
        ordering = ["key"]

    def __str__(self) -> str:
        return f"{self.label} ({self.unit})" if self.unit else self.label
