"""RockBLOCK's delivery webhook, ``POST /api/v1/sbd/rockblock/``.

The provider waits 5 s for an answer and retries what it does not get a 200 for, so the view
does no network I/O and little work: check the JWT against the key file (parsed once), parse
the fields, hand the delivery to sbd_receive. Answers, as JSON: 200 stored or already counted
(a retry), 400 a malformed field, 403 no or a bad signature, 404 an IMEI no vessel has, 503
not configured. Every refusal is logged (without the token).
"""

from __future__ import annotations

import logging

from django.conf import settings
from django.http import HttpRequest, HttpResponse, JsonResponse
from django.views.decorators.csrf import csrf_exempt
from django.views.decorators.http import require_POST

from sbd import signing
from sbd.errors import SbdError
from sbd.rockblock import parse_delivery
from sbd.services import sbd_receive

logger = logging.getLogger(__name__)


def _refuse(request: HttpRequest, exc: SbdError) -> HttpResponse:
    who = request.META.get("REMOTE_ADDR", "?")
    imei = str(request.POST.get("imei", ""))[:20]
    momsn = str(request.POST.get("momsn", ""))[:10]
    logger.warning(
        "SBD delivery refused (%s) from %s, imei %r momsn %r: %s",
        exc.code,
        who,
        imei,
        momsn,
        exc.message,
    )
    return JsonResponse({"error": exc.code, "detail": exc.message}, status=exc.status)


@csrf_exempt
@require_POST
def rockblock_delivery(request: HttpRequest) -> HttpResponse:
    form = request.POST
    try:
        key = signing.public_key(settings.SBD_ROCKBLOCK_PUBLIC_KEY_FILE)
        signing.verify(form, key)
        delivery = parse_delivery(form)
        received = sbd_receive(delivery=delivery)
    except SbdError as exc:
        return _refuse(request, exc)
    if received.duplicate:
        return JsonResponse({"status": "duplicate", "fixes": 0})
    return JsonResponse({"status": "stored", "fixes": received.fixes})
