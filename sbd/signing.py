"""The RockBLOCK delivery's JWT: RS256, signed by the provider, its claims the form's fields.

The public key is read from the PEM file named by SBD_ROCKBLOCK_PUBLIC_KEY_FILE, parsed once
and kept until the file changes (a key rotation is a file replacement, no restart). The token
must verify, must not have expired (when it says when it expires), and every delivery field
it carries must equal the form's: the form is what is parsed, so a signed token glued to
other fields would otherwise vouch for them. ``imei``, ``momsn`` and ``data`` must be claimed.
A replayed post is harmless (the same IMEI and MOMSN are counted once), so no age is imposed
beyond the token's own ``exp``.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Mapping
from typing import Any

import jwt
from cryptography.hazmat.primitives.asymmetric.rsa import RSAPublicKey
from cryptography.hazmat.primitives.serialization import load_pem_public_key

from sbd.errors import NotConfigured, SignatureRefused
from sbd.rockblock import FIELDS

REQUIRED_CLAIMS = ("imei", "momsn", "data")
_lock = threading.Lock()
_cache: dict[str, tuple[tuple[int, int], RSAPublicKey]] = {}


def public_key(path: str) -> RSAPublicKey:
    """The RSA public key in the PEM file ``path``, parsed again only when the file changed."""
    if not path:
        raise NotConfigured(
            "The SBD webhook is not configured: set SBD_ROCKBLOCK_PUBLIC_KEY_FILE to the "
            "provider's public key (PEM)."
        )
    try:
        st = os.stat(path)
    except OSError as exc:
        raise NotConfigured(f"The SBD webhook's public key cannot be read: {exc}") from None
    stamp = (st.st_mtime_ns, st.st_size)
    cached = _cache.get(path)
    if cached and cached[0] == stamp:
        return cached[1]
    with _lock:
        try:
            with open(path, "rb") as handle:
                key = load_pem_public_key(handle.read())
        except (OSError, ValueError) as exc:
            raise NotConfigured(f"The SBD webhook's public key is not a PEM key: {exc}") from None
        if not isinstance(key, RSAPublicKey):
            raise NotConfigured("The SBD webhook's public key is not an RSA key (RS256).")
        _cache[path] = (stamp, key)
    return key


def _same(claim: Any, field: str, value: str) -> bool:
    if str(claim).strip() == value.strip():
        return True
    if field == "data":
        return str(claim).strip().lower() == value.strip().lower()
    if field in ("iridium_latitude", "iridium_longitude", "iridium_cep", "momsn"):
        try:
            return float(claim) == float(value)
        except (TypeError, ValueError):
            return False
    return str(claim).strip() == value.strip()


def verify(form: Mapping[str, str], key: RSAPublicKey) -> dict[str, Any]:
    """The JWT's claims if ``form['JWT']`` is the provider's and vouches for the form's fields;
    SignatureRefused (saying why) otherwise."""
    token = (form.get("JWT") or "").strip()
    if not token:
        raise SignatureRefused("unsigned: no JWT field")
    try:
        claims = jwt.decode(token, key, algorithms=["RS256"], options={"verify_aud": False})
    except jwt.ExpiredSignatureError:
        raise SignatureRefused("the JWT has expired") from None
    except jwt.InvalidTokenError as exc:
        raise SignatureRefused(f"the JWT does not verify: {exc}") from None
    missing = [name for name in REQUIRED_CLAIMS if name not in claims]
    if missing:
        raise SignatureRefused(f"the JWT does not claim {', '.join(missing)}")
    for name in FIELDS:
        if name in claims and not _same(claims[name], name, str(form.get(name, ""))):
            raise SignatureRefused(f"the JWT's {name} differs from the posted {name}")
    return claims
