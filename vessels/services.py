"""Writes for vessels, keys and missions. Admin, API and management commands all come here."""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from django.conf import settings
from django.db import transaction
from django.db.models import F
from django.utils import timezone
from django.utils.text import slugify

from audit.services import audit_record
from vessels import missionfiles, missions, sql
from vessels.errors import MissionCheckError, MissionFileError
from vessels.keys import PREFIX_SHOWN, generate_key, hash_key
from vessels.missionfiles.model import checked_text
from vessels.models import Mission, MissionItem, Vessel, VesselKey


def vessel_create(
    *,
    slug: str,
    name: str,
    kind: str = "mavlink",
    telemetry_period_s: int = 60,
    notes: str = "",
    imei: str | None = None,
) -> Vessel:
    vessel = Vessel(
        slug=slug,
        name=name,
        kind=kind,
        telemetry_period_s=telemetry_period_s,
        notes=notes,
        imei=imei or None,
    )
    vessel.full_clean()
    vessel.save()
    return vessel


def vessel_key_issue(
    *, vessel: Vessel, label: str = "", created_by: str = ""
) -> tuple[VesselKey, str]:
    """Create a key for ``vessel``; return it and the raw key, which is never stored or shown.
    Audited as ``key.issued`` by ``created_by`` (else the origin's actor: audit.context)."""
    raw = generate_key()
    key = VesselKey(
        vessel=vessel,
        label=label,
        created_by=created_by,
        prefix=raw[:PREFIX_SHOWN],
        key_hash=hash_key(raw),
    )
    key.full_clean()
    with transaction.atomic():
        key.save()
        _audit_key("key.issued", key, vessel, actor=created_by)
    return key, raw


@transaction.atomic
def vessel_key_revoke(*, key: VesselKey, now: dt.datetime | None = None) -> VesselKey:
    """Revoke a key at once (idempotent: a revoked key keeps its first revocation time).
    Audited as ``key.revoked`` by the origin's actor (audit.context), the first time only."""
    now = now or timezone.now()
    revoked = VesselKey.objects.filter(pk=key.pk, revoked_at__isnull=True).update(revoked_at=now)
    key.refresh_from_db()
    if revoked:
        _audit_key("key.revoked", key, key.vessel, now=now)
    return key


def _audit_key(
    action: str, key: VesselKey, vessel: Vessel, *, actor: str = "", now: dt.datetime | None = None
) -> None:
    # The prefix and label name the key; the hash never leaves its row.
    audit_record(
        action=action,
        actor=actor,
        subject_type="vessel key",
        subject_id=key.pk,
        subject=f"{key.prefix}… ({key.label or 'no label'}) of {vessel.name}",
        vessel=vessel.slug,
        detail={"prefix": key.prefix, "label": key.label},
        now=now,
    )


def vessel_key_touch(*, key: VesselKey, now: dt.datetime) -> None:
    """Record key use, at most once per KEY_TOUCH_INTERVAL_S.

    Writing on every poll would make every poll a write and serialise them behind SQLite's
    single writer; a minute's resolution is all an operator needs to see a key is in use.
    """
    last = key.last_used_at
    if last is not None and (now - last).total_seconds() < settings.KEY_TOUCH_INTERVAL_S:
        return
    VesselKey.objects.filter(pk=key.pk).update(last_used_at=now)
    Vessel.objects.filter(pk=key.vessel_id).update(last_seen_at=now)
    key.last_used_at = now


def vessel_record_fix(
    *,
    vessel_id: int,
    seen_at: dt.datetime,
    fix_at: dt.datetime | None = None,
    summary: dict[str, Any] | None = None,
) -> None:
    """Mark the vessel seen at ``seen_at``; make ``summary`` its last fix if it is newer
    (decided in the database: vessels.sql.record_fix)."""
    if fix_at is None:
        Vessel.objects.filter(pk=vessel_id).update(last_seen_at=seen_at)
        return
    sql.record_fix(vessel_id=vessel_id, seen_at=seen_at, fix_at=fix_at, summary=summary)


def vessel_bump_commands_version(*, vessel_id: int) -> None:
    """Change the boat poll's ETag: the set of open commands for this vessel changed."""
    Vessel.objects.filter(pk=vessel_id).update(commands_version=F("commands_version") + 1)


@transaction.atomic
def mission_save_items(*, mission: Mission, items: Iterable[Mapping[str, Any]]) -> Mission:
    """Replace a mission's items with ``items`` (dicts of lat, lon and optional hold_s,
    radius_m, speed_mps), numbered 1, 2, … in the order given.

    Raises MissionCheckError past missions.MISSION_MAX_ITEMS: such a mission could never be sent."""
    items = list(items)
    if len(items) > missions.MISSION_MAX_ITEMS:
        raise MissionCheckError(
            [f"the mission has {len(items)} waypoints; at most {missions.MISSION_MAX_ITEMS}"]
        )
    rows = []
    for seq, item in enumerate(items, start=1):
        row = MissionItem(
            mission=mission,
            seq=seq,
            lat=item["lat"],
            lon=item["lon"],
            hold_s=item.get("hold_s") or 0,
            radius_m=item.get("radius_m"),
            speed_mps=item.get("speed_mps"),
        )
        # The field validators only, no query per row: seq is unique by construction, the
        # mission is the one given, and the lat/lon check constraint repeats the validators.
        row.full_clean(exclude=["mission"], validate_unique=False, validate_constraints=False)
        rows.append(row)
    mission.items.all().delete()
    MissionItem.objects.bulk_create(rows)
    Mission.objects.filter(pk=mission.pk).update(updated_at=timezone.now())
    return mission


def vessel_save(*, vessel: Vessel) -> Vessel:
    """Create or update a vessel from an edited instance (admin form)."""
    vessel.full_clean()
    vessel.save()
    return vessel


def vessel_update(*, vessel: Vessel, fields: Mapping[str, Any]) -> Vessel:
    """Change some of an operator's settings of ``vessel`` (the operator API's PATCH).

    Only the given columns are written: a whole-row save would put back the last fix read
    with ``vessel``, undoing a fix ingested meanwhile.
    """
    for name, value in fields.items():
        setattr(vessel, name, value)
    vessel.full_clean()
    vessel.save(update_fields=list(fields))
    return vessel


def mission_save(*, mission: Mission) -> Mission:
    mission.full_clean()
    mission.save()
    return mission


@transaction.atomic
def mission_write(
    *, mission: Mission, fields: Mapping[str, Any], items: Iterable[Mapping[str, Any]] | None
) -> Mission:
    """Create or update ``mission`` with ``fields``; ``items`` replace its items (None keeps
    them: a PATCH without items). The model's checks (both home halves or neither) see the
    mission as it will be, whichever half a partial update gives."""
    for name, value in fields.items():
        setattr(mission, name, value)
    mission = mission_save(mission=mission)
    if items is not None:
        mission_save_items(mission=mission, items=items)
    return mission


def mission_delete(*, mission: Mission) -> None:
    """Delete a mission and its items; commands already sent keep their own copy of them."""
    mission.delete()


def mission_route_problems(*, mission: Mission) -> list[str]:
    """The route checks this mission fails (vessels.missions.problems), [] when none.

    The size the autopilot can store and the vessel's kind are the command catalog's rules:
    every check a send makes is commands.services.mission_send_problems."""
    return missions.problems(
        mission.item_dicts(), max_leg_m=settings.MISSION_MAX_LEG_M, end=mission.end
    )


def mission_summary(*, mission: Mission, vessel: Vessel | None = None) -> missions.Summary:
    """Legs, distances and times of a mission at ``vessel``'s cruise speed (default: the
    mission's own vessel's; a template: the default cruise speed)."""
    vessel = vessel or mission.vessel
    speed = vessel.cruise_speed_mps if vessel else missions.DEFAULT_CRUISE_SPEED_MPS
    return missions.summary(
        mission.item_dicts(), cruise_speed_mps=speed, end=mission.end, home=mission.home
    )


def mission_review(
    *,
    mission: Mission,
    rows: Sequence[Mapping[str, Any]] | None = None,
    end: str | None = None,
    home: tuple[float, float] | None = None,
    vessel: Vessel | None = None,
) -> dict[str, Any]:
    """missions.review of ``mission`` as saved, or of ``rows``/``end``/``home`` as the planner
    shows them (not saved), at ``vessel``'s cruise speed (default: the mission's vessel's) and
    the site's MISSION_MAX_LEG_M: the one source of the figures and checks on the page."""
    vessel = vessel or mission.vessel
    speed = vessel.cruise_speed_mps if vessel else missions.DEFAULT_CRUISE_SPEED_MPS
    return missions.review(
        mission.item_dicts() if rows is None else rows,
        cruise_speed_mps=speed,
        end=end or mission.end,
        home=mission.home if rows is None else home,
        max_leg_m=settings.MISSION_MAX_LEG_M,
    )


@transaction.atomic
def mission_import(
    *,
    content: bytes,
    filename: str = "",
    format: str | None = None,
    vessel: Vessel | None = None,
    name: str = "",
    skip_unsupported: bool = False,
) -> tuple[Mission, list[str]]:
    """Create a mission from a `.plan`, `.waypoints` or GeoJSON file.

    Returns the mission and the items skipped (in words; only with ``skip_unsupported``).
    Raises MissionFileError naming every item the file holds that a mission cannot.
    """
    # The upload's own name and the name given go into the mission too: the same text rule.
    checked_text("the file name", filename)
    checked_text("the name", name)
    parsed = missionfiles.load(
        content, format=format, filename=filename, skip_unsupported=skip_unsupported, name=name
    )
    if len(parsed.items) > missions.MISSION_MAX_ITEMS:
        raise MissionFileError(
            f"the file has {len(parsed.items)} waypoints; a mission holds at most "
            f"{missions.MISSION_MAX_ITEMS}"
        )
    home = parsed.home or (None, None)
    mission = Mission(
        name=(parsed.name or _stem(filename) or "Imported mission")[:_NAME_MAX],
        vessel=vessel,
        end=parsed.end,
        home_lat=home[0],
        home_lon=home[1],
        notes=_import_note(filename, parsed.skipped),
    )
    mission_save(mission=mission)
    mission_save_items(mission=mission, items=[item.as_dict() for item in parsed.items])
    return mission, list(parsed.skipped)


_NAME_MAX = Mission._meta.get_field("name").max_length


def _stem(filename: str) -> str:
    base = filename.replace("\\", "/").rsplit("/", 1)[-1]
    return base.rsplit(".", 1)[0] if "." in base else base


def _import_note(filename: str, skipped: Iterable[str]) -> str:
    lines = [f"Imported from {filename or 'a file'}."]
    lines += [f"Skipped {item}" for item in skipped]
    return "\n".join(lines)


def mission_export(*, mission: Mission, format: str) -> tuple[str, str, str]:
    """The mission as a file: (content, content type, file name). Raises MissionFileError
    for an unknown format."""
    vessel = mission.vessel
    exported = missionfiles.dump(
        missionfiles.MissionFile(
            items=tuple(missionfiles.Item(**item) for item in mission.item_dicts()),
            end=mission.end,
            home=mission.home,
            name=mission.name,
        ),
        format,
        cruise_speed_mps=vessel.cruise_speed_mps if vessel else missions.DEFAULT_CRUISE_SPEED_MPS,
    )
    filename = f"{slugify(mission.name) or 'mission'}.{exported.extension}"
    return exported.content, exported.content_type, filename
