from __future__ import annotations

from django.db import models
from django.db.models import Q

from vessels.models import IN_RANGE, Vessel


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
                condition=IN_RANGE,  # the contract's range, as the parser's
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
        indexes = [
            models.Index(fields=["-recorded_at"], name="fix_recorded_desc"),
            # The alerts evaluator's "fixes received since the last pass" (alerts/evaluator.py).
            models.Index(fields=["received_at"], name="fix_received_at"),
        ]

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


class TrackBucket(models.Model):
    """A summary of a vessel's fixes in one time bucket: the track overview (telemetry/overview.py).

    Derived data, rebuilt from the fixes (the finest width) or from the next finer buckets by
    services.track_overview_refresh; never edited. Lets a month of track or plots be read from
    a few thousand rows instead of a million fixes.
    """

    vessel = models.ForeignKey(Vessel, on_delete=models.CASCADE, related_name="+")
    width = models.PositiveIntegerField(help_text="Bucket length, seconds.")
    start = models.BigIntegerField(help_text="Bucket start, Unix seconds.")
    count = models.PositiveIntegerField()
    # [first, last, north, south, east, west, gap_from, gap_to], each [t, lat, lon] or null.
    points = models.JSONField()
    # reading key ("" for battery_v) -> [min, max, sum, count]
    channels = models.JSONField(default=dict)

    class Meta:
        constraints = [
            # Also the index every overview read walks: (vessel, width, start range).
            models.UniqueConstraint(fields=["vessel", "width", "start"], name="trackbucket_unique")
        ]


class TrackDirty(models.Model):
    """A minute of a vessel's track whose overview buckets are out of date.

    Ingest adds one per minute it stored a fix in (late store-and-forward fixes included), in
    the same statement or transaction as the fixes; `rebuild_track_overview --loop` rebuilds and
    clears them, and until then reads take the minute's fixes instead of its buckets. Cheap to
    write, and a reader never uses a bucket older than the fixes it summarises.
    """

    vessel = models.ForeignKey(Vessel, on_delete=models.CASCADE, related_name="+")
    start = models.BigIntegerField(help_text="Minute start, Unix seconds.")

    class Meta:
        constraints = [
            models.UniqueConstraint(fields=["vessel", "start"], name="trackdirty_unique")
        ]


class FixThinning(models.Model):
    """How far retention has thinned a vessel's fixes (telemetry/retention.py).

    Every interval of ``interval_s`` wholly before ``thinned_before`` holds only its first and
    last fix and the fixes kept for their own sake: the next prune starts there instead of
    reading the vessel's whole thinned history again. A prune with another interval starts over.
    """

    vessel = models.OneToOneField(
        Vessel, on_delete=models.CASCADE, primary_key=True, related_name="+"
    )
    interval_s = models.PositiveIntegerField()
    thinned_before = models.DateTimeField()
