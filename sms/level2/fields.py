"""Level 2 field helpers shared by the bodies: coordinates as minutes × 10⁴ (§8.3 of
docs/level2.md) and the checks every ``from_bytes`` makes. Pure, no I/O.
"""

from __future__ import annotations

from .errors import BodyError, LocalProtocolError

# --- coordinates (§8.3) -------------------------------------------------------------------

UNITS_PER_DEGREE = 600_000  # §8.3: minutes × 10⁴, i.e. decimal degrees × 600000


def degrees_to_l2(degrees: float, *, limit: float = 180.0) -> int:
    """Decimal degrees → the protocol's signed minutes × 10⁴ integer (§8.3).

    South and west are negative; degrees and minutes share the sign, so rounding
    ``degrees × 600000`` gives the same integer as the handbook's composition.
    """
    if not -limit <= degrees <= limit:
        raise LocalProtocolError(f"{degrees} is outside ±{limit} degrees")
    return round(degrees * UNITS_PER_DEGREE)


def l2_to_degrees(value: int) -> float:
    """The protocol's minutes × 10⁴ integer → decimal degrees (§8.3)."""
    return value / UNITS_PER_DEGREE


def format_l2(value: int, positive: str, negative: str) -> str:
    """36°48.1669'N style text of a minutes × 10⁴ value, as the protocol page writes them."""
    hemi = positive if value >= 0 else negative
    value = abs(value)
    return f"{value // UNITS_PER_DEGREE}°{(value % UNITS_PER_DEGREE) / 10_000:.4f}'{hemi}"


def need_bytes(data: bytes, size: int, what: str) -> None:
    """Raise :class:`BodyError` when ``data`` is shorter than a ``what`` needs."""
    if len(data) < size:
        raise BodyError(f"{what}: {len(data)} bytes, need {size}")


def ascii_text(raw: bytes) -> str:
    """A fixed-size text field (serial, description): ASCII, anything else replaced."""
    return raw.decode("ascii", "replace")
