"""A mobile-originated delivery: counted once, its fixes into the telemetry ingest."""

from __future__ import annotations

import datetime as dt
import logging
from dataclasses import dataclass

from django.db import IntegrityError, transaction
from django.utils import timezone

from sbd.errors import UnknownImei
from sbd.models import Direction, SbdMessage, Status
from sbd.payload import PayloadError, fixes_from_payload, iridium_fix
from sbd.rockblock import Delivery
from telemetry.services import fix_ingest
from vessels.models import Vessel

logger = logging.getLogger(__name__)
DETAIL_MAX = 200


@dataclass(frozen=True)
class Received:
    """What became of a delivery: ``duplicate`` when it had been counted before."""

    message: SbdMessage | None
    duplicate: bool = False
    fixes: int = 0


def sbd_receive(*, delivery: Delivery, now: dt.datetime | None = None) -> Received:
    """File ``delivery`` under the vessel with its IMEI, once; ingest its fixes.

    The payload's fixes when it holds any; else the Iridium position at the transmit time
    (reading ``iridium_cep_km``), also when the payload cannot be decoded: the position is the
    network's, true whatever the boat sent, and for a vessel heard only by satellite it may be
    the only one there is (the refusal is logged and kept in the message's detail).
    UnknownImei, nothing stored, when no vessel has the IMEI.
    """
    now = now or timezone.now()
    vessel = Vessel.objects.filter(imei=delivery.imei).first()
    if vessel is None:
        raise UnknownImei(f"no vessel has the IMEI {delivery.imei}")
    # The provider's retry, answered before any decoding; the constraint below still decides
    # when two copies race.
    if SbdMessage.objects.filter(
        direction=Direction.IN,
        imei=delivery.imei,
        momsn=delivery.momsn,
        transmit_time=delivery.transmit_time,
    ).exists():
        return Received(message=None, duplicate=True)
    status, detail = Status.DECODED, ""
    try:
        fixes = fixes_from_payload(vessel, delivery.data)
    except PayloadError as exc:
        fixes, status, detail = [], Status.UNDECODABLE, f"payload refused: {exc}"[:DETAIL_MAX]
        logger.warning(
            "SBD %s MOMSN %d (%s): %s", delivery.imei, delivery.momsn, vessel.slug, detail
        )
    if not fixes:
        fixes = [iridium_fix(delivery)]
        if status == Status.DECODED:
            status = Status.POSITION_ONLY
    message = SbdMessage(
        direction=Direction.IN,
        vessel=vessel,
        imei=delivery.imei,
        momsn=delivery.momsn,
        received_at=now,
        transmit_time=delivery.transmit_time,
        iridium_lat=delivery.lat,
        iridium_lon=delivery.lon,
        iridium_cep_km=delivery.cep_km,
        payload=delivery.data,
        bytes=len(delivery.data),
        status=status,
        detail=detail,
    )
    with transaction.atomic():
        try:
            with transaction.atomic():
                message.save()
        except IntegrityError:
            return Received(message=None, duplicate=True)
        result = fix_ingest(vessel=vessel, records=fixes, now=now)
        if result.rejected:
            problems = "; ".join(f"{r}" for r in result.rejected)
            message.detail = (f"{detail}; " if detail else "") + f"fixes refused: {problems}"
            message.detail = message.detail[:DETAIL_MAX]
            logger.warning("SBD %s MOMSN %d: %s", delivery.imei, delivery.momsn, message.detail)
        message.fixes = result.accepted
        message.save(update_fields=["fixes", "detail"])
    return Received(message=message, fixes=result.accepted)
