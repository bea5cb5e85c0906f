"""Mobile-terminated messages out through the provider's HTTP API, behind one small interface.

``MtTransport.send(imei, data)`` hands one message to the provider and returns its id for the
message, or raises MtError (``permanent`` when sending it again cannot help). RockBlockMt is
RockBLOCK's: a form POST of imei, username, password and the data in hex to its MT endpoint,
answered "OK,<id>" or "FAILED,<code>,<text>". Tests run it against a local HTTP server.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import requests
from django.conf import settings

from sbd.errors import MtError
from sbd.rockblock import parse_mt_answer

TEMPORARY_4XX = {408, 429}


class MtTransport(Protocol):
    def send(self, imei: str, data: bytes) -> str: ...


@dataclass(frozen=True)
class RockBlockMt:
    url: str
    username: str
    password: str
    timeout_s: float = 10.0

    def send(self, imei: str, data: bytes) -> str:
        form = {
            "imei": imei,
            "username": self.username,
            "password": self.password,
            "data": data.hex(),
        }
        try:
            response = requests.post(
                self.url, data=form, timeout=self.timeout_s, allow_redirects=False
            )
        except requests.Timeout:
            raise MtError(f"no answer from the SBD provider within {self.timeout_s:g} s") from None
        except requests.RequestException as exc:
            # The exception's text may hold the URL, never the form: no password in the log.
            reason = exc.__class__.__name__
            raise MtError(f"the SBD provider could not be reached: {reason}") from None
        status = response.status_code
        if not 200 <= status < 300:
            permanent = 300 <= status < 500 and status not in TEMPORARY_4XX
            raise MtError(f"the SBD provider answered HTTP {status}", permanent=permanent)
        return parse_mt_answer(response.text)


def configured_transport() -> MtTransport | None:
    """RockBLOCK's MT API as the settings have it; None when no user name is set (off)."""
    if not settings.SBD_ROCKBLOCK_USERNAME or not settings.SBD_ROCKBLOCK_MT_URL:
        return None
    return RockBlockMt(
        url=settings.SBD_ROCKBLOCK_MT_URL,
        username=settings.SBD_ROCKBLOCK_USERNAME,
        password=settings.SBD_ROCKBLOCK_PASSWORD,
        timeout_s=settings.SBD_HTTP_TIMEOUT_S,
    )
