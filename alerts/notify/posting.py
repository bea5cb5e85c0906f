"""One HTTP POST with a timeout, its outcome told as TransportError(permanent=…).

Shared by the webhook and the HTTP SMS gateway. What is worth a retry: a timeout, a refused or
dropped connection, a 5xx, and of the 4xx only 408 (Request Timeout) and 429 (Too Many Requests,
RFC 6585). Any other 4xx means the request itself is wrong (a 404, a 401 from a changed secret):
sending it again changes nothing. Redirects are not followed (a POST turned into a GET loses its
body), so a 3xx is permanent too: the channel's URL needs correcting.
"""

from __future__ import annotations

import requests

from .base import TransportError

TEMPORARY_4XX = {408, 429}
USER_AGENT = "Shoreside-alerts/1"
_ERROR_TEXT = 200  # characters of a refusal's body kept in the error (and so in last_error)


def post(url: str, body: bytes, headers: dict[str, str], timeout_s: float) -> None:
    """POST ``body`` (JSON) to ``url``; return on any 2xx, raise TransportError otherwise."""
    sent = {"Content-Type": "application/json", "User-Agent": USER_AGENT, **headers}
    try:
        response = requests.post(
            url, data=body, headers=sent, timeout=timeout_s, allow_redirects=False
        )
    except requests.Timeout:
        raise TransportError(f"no answer from {url} within {timeout_s:g} s") from None
    except requests.RequestException as exc:
        raise TransportError(f"{url}: {exc.__class__.__name__}: {exc}") from None
    status = response.status_code
    if 200 <= status < 300:
        return
    text = " ".join(response.text.split())[:_ERROR_TEXT]
    reason = f"{url} answered {status} {response.reason or ''}".rstrip()
    if text:
        reason += f": {text}"
    if 300 <= status < 400:
        where = response.headers.get("Location", "?")
        raise TransportError(f"{reason} (redirect to {where}; correct the URL)", permanent=True)
    permanent = 400 <= status < 500 and status not in TEMPORARY_4XX
    raise TransportError(reason, permanent=permanent)
