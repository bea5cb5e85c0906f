from __future__ import annotations

import datetime as dt
from typing import Any

from django.core.exceptions import ValidationError
from django.core.validators import MaxValueValidator, MinValueValidator, RegexValidator
from django.db import models
from django.db.models import Q

from edge_client.contract import fix as fix_shape
from edge_client.contract.compact import Channel, CompactError, channels_from
from edge_client.contract.kinds import MAVLINK, WAVE_GLIDER
from vessels import fences
from vessels.fences import FenceError
from vessels.missions import (
    DEFAULT_CRUISE_SPEED_MPS,
    HOLD_MAX_S,
    ITEM_FIELDS,
    RADIUS_MAX_M,
    RADIUS_MIN_M,
    SPEED_MAX_MPS,
    SPEED_MIN_MPS,
)

# A vessel silent for this many telemetry periods is overdue (docs/operating.md#the-admin).
OVERDUE_PERIODS = 3
# An Iridium modem's IMEI: 15 digits, how the SBD provider names the vessel's modem.
IMEI_VALIDATOR = RegexValidator(r"^[0-9]{15}\Z", "An IMEI is 15 digits.")
# The vessel's own phone number, stored as the SMS log stores numbers: E.164.
E164_VALIDATOR = RegexValidator(r"^\+[1-9][0-9]{6,14}\Z", "An E.164 number: + and 7-15 digits.")
# Half the Earth's circumference: no two points are farther apart, so no limit needs more.
MOVE_TO_MAX_LIMIT_M = 20_038_000


class VesselKind(models.TextChoices):
    MAVLINK = MAVLINK, "ArduPilot (MAVLink)"
    WAVE_GLIDER = WAVE_GLIDER, "Wave Glider"


class Vessel(models.Model):
    name = models.CharField(max_length=100)
    slug = models.SlugField(max_length=50, unique=True, help_text="Stable id used in URLs.")
    kind = models.CharField(max_length=20, choices=VesselKind.choices, default=VesselKind.MAVLINK)
    active = models.BooleanField(default=True)
    notes = models.TextField(blank=True)
    telemetry_period_s = models.PositiveIntegerField(
        default=60,
        validators=[MinValueValidator(1), MaxValueValidator(7 * 86400)],
        help_text="Expected seconds between reports.",
    )
    cruise_speed_mps = models.FloatField(
        "cruise speed (m/s)",
        default=DEFAULT_CRUISE_SPEED_MPS,
        validators=[MinValueValidator(SPEED_MIN_MPS), MaxValueValidator(SPEED_MAX_MPS)],
        help_text="Usual speed through the water; mission times are estimated with it.",
    )
    # A move_to farther than this from the last fix is refused (commands.catalog): a slip of
    # the mouse or a swapped coordinate must not send the boat across an ocean.
    move_to_max_m = models.PositiveIntegerField(
        "move_to limit (m)",
        null=True,
        blank=True,
        validators=[MaxValueValidator(MOVE_TO_MAX_LIMIT_M)],
        help_text="How far from its last fix a move_to may send it. Empty: the site default "
        "(MOVE_TO_MAX_M); 0: no limit.",
    )
    # The readings a compact payload carries, by index (edge_client/contract/compact.py): the
    # boat's configuration lists the same, or its readings are refused, not misread.
    compact_channels = models.JSONField(
        "compact channel table",
        default=list,
        blank=True,
        help_text='Readings in compact payloads, in order: [{"name": "humidity_pct", "step": '
        "0.1}, …]; each value is kept to its step. The boat's configuration must list the same.",
    )
    # Null, not blank, when there is none: unique, and many vessels have no Iridium modem.
    imei = models.CharField(
        "Iridium IMEI",
        max_length=15,
        unique=True,
        null=True,
        blank=True,
        validators=[IMEI_VALIDATOR],
        help_text="The IMEI of the vessel's Iridium SBD modem (15 digits): its messages "
        "through the SBD provider are filed under this vessel. Empty: none.",
    )
    # The vessel's own phone (a glider's SIM): the shore texts commands to it when its HTTP
    # link is silent (links.routing). The shore's sender must be authorised on the vessel.
    sms_number = models.CharField(
        "SMS number",
        max_length=20,
        blank=True,
        validators=[E164_VALIDATOR],
        help_text="The vessel's own phone number, E.164 (+61412345678): commands go to it by "
        "SMS when its HTTP link is silent, or when urgent. Empty: none.",
    )
    # Daily budgets per link (links app, alert rule kind "budget"): crossing one opens an alert.
    sbd_daily_credit_budget = models.PositiveIntegerField(
        "SBD credits a day",
        null=True,
        blank=True,
        help_text="Iridium SBD credits (50 bytes each, in and out) a UTC day; crossing it "
        "raises a budget alert. Empty: no budget.",
    )
    sms_daily_budget = models.PositiveIntegerField(
        "SMS a day",
        null=True,
        blank=True,
        help_text="SMS segments (in and out) a UTC day; crossing it raises a budget alert. "
        "Empty: no budget.",
    )
    http_daily_budget_kb = models.PositiveIntegerField(
        "HTTP kB a day",
        null=True,
        blank=True,
        help_text="Boat API kilobytes (1000 bytes, in and out) a UTC day; crossing it raises "
        "a budget alert. Empty: no budget.",
    )
    # Denormalised newest fix for the fleet list and map: {time, lat, lon, heading_deg, ...}.
    last_fix = models.JSONField(null=True, blank=True, editable=False)
    last_fix_at = models.DateTimeField(null=True, blank=True, editable=False)
    last_seen_at = models.DateTimeField(null=True, blank=True, editable=False)
    # Bumped whenever the set of open commands for this vessel changes; the boat poll's ETag.
    commands_version = models.PositiveBigIntegerField(default=0, editable=False)
    created_at = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["name"]

    def __str__(self) -> str:
        return self.name

    def clean(self) -> None:
        super().clean()
        try:
            self.channel_table()
        except CompactError as exc:
            raise ValidationError({"compact_channels": str(exc)}) from None

    def channel_table(self) -> list[Channel]:
        """The compact channel table (CompactError if the stored JSON is not one)."""
        if not isinstance(self.compact_channels, list):
            raise CompactError("a channel table is a JSON list")
        return channels_from(self.compact_channels)

    def status(self, now: dt.datetime) -> str:
        """`never seen`, `reporting` or `overdue` (silent for OVERDUE_PERIODS periods)."""
        if self.last_seen_at is None:
            return "never seen"
        if self.is_overdue(now):
            return "overdue"
        return "reporting"

    def is_overdue(self, now: dt.datetime) -> bool:
        if self.last_seen_at is None:
            return False
        limit = dt.timedelta(seconds=self.telemetry_period_s * OVERDUE_PERIODS)
        return now - self.last_seen_at > limit

    @property
    def battery_v(self) -> float | None:
        fix: dict[str, Any] = self.last_fix or {}
        return fix.get("battery_v")


class VesselKey(models.Model):
    vessel = models.ForeignKey(Vessel, on_delete=models.CASCADE, related_name="keys")
    label = models.CharField(max_length=100, blank=True)
    # First characters of the key, to tell keys apart in the admin without revealing them.
    prefix = models.CharField(max_length=12, editable=False)
    # SHA-256 of the key. Keys are 256-bit random, so a fast hash is safe and keeps auth cheap.
    key_hash = models.CharField(max_length=64, unique=True, editable=False)
    created_at = models.DateTimeField(auto_now_add=True)
    created_by = models.CharField(max_length=150, blank=True)
    revoked_at = models.DateTimeField(null=True, blank=True, editable=False)
    last_used_at = models.DateTimeField(null=True, blank=True, editable=False)

    class Meta:
        ordering = ["-created_at"]
        verbose_name = "vessel key"

    def __str__(self) -> str:
        return f"{self.prefix}… ({self.vessel.slug})"

    @property
    def is_active(self) -> bool:
        return self.revoked_at is None


class MissionEnd(models.TextChoices):
    # ArduPilot: nothing after the last item, a DO_JUMP to item 1, a NAV_RETURN_TO_LAUNCH.
    STOP = "stop", "Stop at the last waypoint"
    LOOP = "loop", "Loop back to the first waypoint"
    RETURN_HOME = "return_home", "Return home"


# A position's range is a fix's (the contract's), here as validators and as a check.
(LAT_MIN, LAT_MAX), (LON_MIN, LON_MAX) = fix_shape.RANGES["lat"], fix_shape.RANGES["lon"]
_LAT = [MinValueValidator(LAT_MIN), MaxValueValidator(LAT_MAX)]
_LON = [MinValueValidator(LON_MIN), MaxValueValidator(LON_MAX)]
IN_RANGE = Q(lat__gte=LAT_MIN, lat__lte=LAT_MAX, lon__gte=LON_MIN, lon__lte=LON_MAX)


class Mission(models.Model):
    name = models.CharField(max_length=100)
    vessel = models.ForeignKey(
        Vessel,
        on_delete=models.CASCADE,
        null=True,
        blank=True,
        related_name="missions",
        help_text="Leave empty for a template any vessel can run.",
    )
    end = models.CharField(max_length=12, choices=MissionEnd.choices, default=MissionEnd.STOP)
    # The planned home (QGC's plannedHomePosition, a .waypoints file's row 0): where the boat
    # is launched, for the return leg and for export. Not a waypoint; the boat's real home is
    # where the autopilot sets it.
    home_lat = models.FloatField("home latitude", null=True, blank=True, validators=_LAT)
    home_lon = models.FloatField("home longitude", null=True, blank=True, validators=_LON)
    notes = models.TextField(blank=True)
    created_at = models.DateTimeField(auto_now_add=True)
    updated_at = models.DateTimeField(auto_now=True)

    class Meta:
        ordering = ["name"]

    def __str__(self) -> str:
        return self.name

    def clean(self) -> None:
        if (self.home_lat is None) != (self.home_lon is None):
            raise ValidationError(
                {"home_lat": "Give both home latitude and longitude, or neither."}
            )

    @property
    def home(self) -> tuple[float, float] | None:
        if self.home_lat is None or self.home_lon is None:
            return None
        return self.home_lat, self.home_lon

    def item_dicts(self) -> list[dict[str, Any]]:
        return [item.as_dict() for item in self.items.all()]

    def as_params(self) -> dict[str, Any]:
        """The `mission` command params for this mission (validated by the catalog on enqueue,
        which also fills in the older ``loop`` flag from ``end``)."""
        return {"mission_id": self.pk, "end": self.end, "items": self.item_dicts()}


class MissionItem(models.Model):
    mission = models.ForeignKey(Mission, on_delete=models.CASCADE, related_name="items")
    seq = models.PositiveIntegerField()
    lat = models.FloatField(validators=_LAT)
    lon = models.FloatField(validators=_LON)
    hold_s = models.FloatField(
        "hold (s)", default=0, validators=[MinValueValidator(0), MaxValueValidator(HOLD_MAX_S)]
    )
    radius_m = models.FloatField(
        "radius (m)",
        null=True,
        blank=True,
        validators=[MinValueValidator(RADIUS_MIN_M), MaxValueValidator(RADIUS_MAX_M)],
        help_text="Acceptance radius; empty: the autopilot's own (WP_RADIUS).",
    )
    speed_mps = models.FloatField(
        "speed (m/s)",
        null=True,
        blank=True,
        validators=[MinValueValidator(SPEED_MIN_MPS), MaxValueValidator(SPEED_MAX_MPS)],
        help_text="Speed from this waypoint on (the leg to it included); empty: unchanged.",
    )

    class Meta:
        ordering = ["mission", "seq"]
        constraints = [
            models.UniqueConstraint(fields=["mission", "seq"], name="missionitem_unique_seq"),
            models.CheckConstraint(
                condition=IN_RANGE,
                name="missionitem_latlon_range",
            ),
        ]

    def __str__(self) -> str:
        return f"{self.seq}: {self.lat:.5f}, {self.lon:.5f}"

    def as_dict(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in ITEM_FIELDS}


class Fence(models.Model):
    """An area a vessel must stay inside (inclusion) or outside (exclusion): a polygon, or a
    circle (a GeoJSON Point with ``radius_m``). The alerts' fence rules watch it on the shore;
    the `fence` command loads the same geometry into an ArduPilot boat's autopilot."""

    name = models.CharField(max_length=100)
    vessel = models.ForeignKey(
        Vessel,
        on_delete=models.CASCADE,
        null=True,
        blank=True,
        related_name="fences",
        help_text="Leave empty for a fence every vessel keeps.",
    )
    inclusion = models.BooleanField(
        default=True, help_text="Stay inside (inclusion) or stay out (exclusion)."
    )
    # GeoJSON geometry, [lon, lat] order as GeoJSON has it: a Polygon (outer ring only, closed)
    # or a Point, the centre of a circle of radius_m.
    geometry = models.JSONField()
    radius_m = models.FloatField("radius (m)", null=True, blank=True)
    notes = models.TextField(blank=True)
    created_at = models.DateTimeField(auto_now_add=True)
    updated_at = models.DateTimeField(auto_now=True)

    class Meta:
        ordering = ["name"]

    def __str__(self) -> str:
        return self.name

    def clean(self) -> None:
        # One shape for every way in (map, API, file): vessels.fences.
        try:
            self.geometry, self.radius_m = fences.clean(self.geometry, self.radius_m)
        except FenceError as exc:
            field = "radius_m" if "radius_m" in exc.message else "geometry"
            raise ValidationError({field: exc.problems}) from None

    @property
    def shape(self) -> str:
        return fences.describe(self.geometry, self.radius_m)
