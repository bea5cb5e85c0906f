"""Create a demo fleet: an operator account, vessels with keys, sensor channels, some history."""

from __future__ import annotations

import datetime as dt
import json
import secrets
from pathlib import Path
from typing import Any

from django.conf import settings
from django.contrib.auth.models import Group, Permission, User
from django.core.management.base import CommandParser
from django.db import transaction
from django.utils import timezone

from alerts.models import AlertRule
from audit.context import AuditedCommand
from commands.models import Source
from commands.services import command_ack, command_claim_open, command_enqueue
from edge_client.contract.status import Status
from fleet.demo_track import SimBoat, patrol_route
from fleet.files import write_private
from sms.services import authorised_number_authorise
from telemetry.models import SensorChannel
from telemetry.services import fix_ingest, sensor_channel_save
from vessels.models import Mission, Vessel
from vessels.services import mission_save, mission_save_items, vessel_create, vessel_key_issue

OPERATOR_GROUP = "Operators"
OPERATOR_PERMS = {
    "vessels": [
        "view_vessel",
        "change_vessel",
        "add_vessel",
        "view_vesselkey",
        "add_vesselkey",
        "change_vesselkey",
        "view_mission",
        "add_mission",
        "change_mission",
        "delete_mission",
        "view_missionitem",
        "add_missionitem",
        "change_missionitem",
        "delete_missionitem",
        "view_fence",
        "add_fence",
        "change_fence",
        "delete_fence",
    ],
    "telemetry": ["view_fix", "view_sensorchannel", "add_sensorchannel", "change_sensorchannel"],
    "commands": ["view_command", "add_command", "change_command", "view_commandevent"],
    "sms": ["view_authorisednumber", "add_authorisednumber", "change_authorisednumber",
            "view_smsmessage"],
    "audit": ["view_auditentry"],
    # Watching the fleet (docs/alerts.md): the map's alert badges need view_alert.
    "alerts": ["view_alertrule", "add_alertrule", "change_alertrule", "delete_alertrule",
               "view_alert", "change_alert", "view_notificationchannel",
               "add_notificationchannel", "change_notificationchannel"],
}  # fmt: skip
# A field user's phone that may command the demo glider (docs/development.md; manage.py demo_sms).
DEMO_NUMBER = "+61400000001"
DEMO_VESSELS = [
    # slug, name, kind, start (lat, lon), telemetry period
    # At sea off Fremantle (Gage Roads), where the offline coastline shows water around them.
    ("spab", "SPAB", "mavlink", (-32.0200, 115.7000), 10),
    ("spab-2", "SPAB 2", "mavlink", (-32.0500, 115.6800), 10),
    # Off Fremantle, where the demo's live glider (simulate_glider) starts.
    ("glider", "Wave Glider", "wave_glider", (-32.0800, 115.7000), 300),
]
CHANNELS = [
    ("water_temp_c", "Water temperature", "°C", 10, 30),
    ("salinity_psu", "Salinity", "PSU", 30, 40),
    ("humidity_pct", "Hull humidity", "%", 0, 100),
    # The live glider's payload board (sms/bridge/sensor_layouts.toml, record "stasis").
    ("humidity_temp_c", "Hull temperature", "°C", 0, 50),
    ("pressure_kpa", "Hull pressure", "kPa", 80, 120),
    ("pressure_temp_c", "Pressure sensor temperature", "°C", 0, 50),
    ("leak1", "Leak sensor 1", "", 0, 1),
    ("leak2", "Leak sensor 2", "", 0, 1),
]
HISTORY = dt.timedelta(hours=3)
# The alerts run_alerts watches in the demo (docs/operating.md): name, fields.
ALERT_RULES = [
    ("Silent for 3 periods", {"kind": "overdue", "threshold": 3}),
    # The simulated Rover's battery sags from 12.6 V as it runs: the demo shows one open.
    ("Boat battery low", {"kind": "battery", "threshold": 11.5, "vessel_kind": "mavlink"}),
    # The glider's hull humidity rising means a leak; the channel's 0-100 % is too wide.
    ("Glider hull humidity", {"kind": "reading", "reading": "humidity_pct", "maximum": 70,
                              "vessel_kind": "wave_glider"}),
]  # fmt: skip


class Command(AuditedCommand):  # its keys, numbers and commands audited as the shell user
    help = "Create a demo fleet with an operator login, vessel keys and a few hours of history."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("--password", help="operator password (default: random, printed)")
        parser.add_argument(
            "--keys-file",
            default=str(Path(settings.DATA_DIR) / "demo-keys.json"),
            help="where to write the demo vessels' keys (mode 600)",
        )

    @transaction.atomic
    def handle(self, *args: Any, **opts: Any) -> None:
        password = opts["password"] or secrets.token_urlsafe(9)
        user = self.operator(password)
        for key, label, unit, lo, hi in CHANNELS:
            if not SensorChannel.objects.filter(key=key).exists():
                sensor_channel_save(
                    channel=SensorChannel(key=key, label=label, unit=unit, minimum=lo, maximum=hi)
                )
        keys: dict[str, str] = {}
        for slug, name, kind, start, period in DEMO_VESSELS:
            vessel = Vessel.objects.filter(slug=slug).first()
            if vessel is None:
                vessel = vessel_create(slug=slug, name=name, kind=kind, telemetry_period_s=period)
                self.history(vessel, start, period)
            keys[slug] = vessel_key_issue(vessel=vessel, label="demo", created_by="seed_demo")[1]
        self.demo_commands(user)
        self.alert_rules()
        authorised_number_authorise(
            number=DEMO_NUMBER,
            vessels=[Vessel.objects.get(slug="glider")],
            role="control",
            name="Demo field phone",
        )
        path = Path(opts["keys_file"])
        path.parent.mkdir(parents=True, exist_ok=True)
        path.unlink(missing_ok=True)  # recreated private; os.open keeps an old file's mode
        write_private(path, json.dumps(keys, indent=1))
        self.stdout.write(self.style.SUCCESS("Demo fleet ready."))
        self.stdout.write(f"  Log in at /admin/ as  user: {user.username}  password: {password}")
        self.stdout.write(f"  Vessel keys (new ones, shown once) are in {path}")
        self.stdout.write(
            f"  Text the glider: manage.py sms_inject --vessel glider --from {DEMO_NUMBER}"
            ' --text "#STATUS"'
        )

    def operator(self, password: str) -> User:
        group, _ = Group.objects.get_or_create(name=OPERATOR_GROUP)
        for app, codenames in OPERATOR_PERMS.items():
            group.permissions.add(
                *Permission.objects.filter(content_type__app_label=app, codename__in=codenames)
            )
        user, _ = User.objects.get_or_create(
            username="operator", defaults={"email": "operator@example.org"}
        )
        user.is_staff = True
        user.set_password(password)
        user.save()
        user.groups.add(group)
        return user

    def history(self, vessel: Vessel, start: tuple[float, float], period: int) -> None:
        now = timezone.now()
        boat = SimBoat(
            lat=start[0],
            lon=start[1],
            speed_mps=1.0 if period > 60 else 2.0,
            route=patrol_route(*start, radius_m=600),
        )
        step = max(period, 30)
        t = now - HISTORY
        records = []
        while t < now:
            boat.step(step)
            records.append(boat.fix(t))
            t += dt.timedelta(seconds=step)
        fix_ingest(vessel=vessel, records=records, now=now)

    def demo_commands(self, user: User) -> None:
        spab = Vessel.objects.get(slug="spab")
        if spab.commands.exists():
            return
        done = command_enqueue(
            vessel=spab,
            kind="move_to",
            params={"lat": -32.0210, "lon": 115.7030},
            source=Source.ADMIN,
            created_by=user.username,
        )
        command_claim_open(vessel=spab)
        command_ack(vessel=spab, uid=done.uid, status=Status.ACKNOWLEDGED)
        command_ack(vessel=spab, uid=done.uid, status=Status.DONE, detail="arrived")
        mission = mission_save(mission=Mission(name="Gage Roads loop", vessel=spab, end="loop"))
        mission_save_items(
            mission=mission,
            items=[
                {"lat": lat, "lon": lon, "hold_s": 0, "radius_m": 5}
                for lat, lon in patrol_route(-32.0200, 115.7000, radius_m=300, points=5)
            ],
        )

    def alert_rules(self) -> None:
        for name, fields in ALERT_RULES:
            if not AlertRule.objects.filter(name=name).exists():
                rule = AlertRule(name=name, **fields)
                rule.full_clean()
                rule.save()
