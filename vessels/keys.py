"""Vessel API keys: generation and hashing. Pure (no ORM)."""

from __future__ import annotations

import hashlib
import secrets

KEY_PREFIX = "ssk_"  # makes a leaked key easy to recognise in logs and secret scanners
PREFIX_SHOWN = 12


def generate_key() -> str:
    # 32 random bytes = 256 bits: guessing is hopeless, so one fast hash suffices (no KDF).
    return KEY_PREFIX + secrets.token_urlsafe(32)


def hash_key(raw_key: str) -> str:
    return hashlib.sha256(raw_key.encode("utf-8", "surrogatepass")).hexdigest()
