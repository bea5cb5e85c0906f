"""What the ISU's session results mean and whether to try again. Pure.

Reference: Iridium's ISU AT Command Reference (and the 9602/9603 Developer's Guides), ``+SBDIX``
(``<MO status>``, ``<MT status>``) and ``+SBDWB`` (the write result), as publicly documented.

The retry decision for an MO status:

* ``RETRY``: the sky or the network was not with us this time (no service, RF drop, gateway
  timeout, modem busy): try again after the contract's backoff;
* ``WAIT``: the network told us to hold off (3 minutes since the last registration, traffic
  management, service disabled, gateway queue full): try again, but not before ``min_wait_s``;
* ``NEVER``: the modem or the account needs a person, or the message itself is wrong (locked,
  radio disabled, access denied, antenna or PLL fault, band violation, bad segments).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


class Retry(Enum):
    NONE = "none"  # the session succeeded
    RETRY = "retry"
    WAIT = "wait"
    NEVER = "never"


# Seconds to hold off after a WAIT status: 36 says 3 minutes outright; for the others the
# reference gives no figure, and a few minutes keeps a boat from burning its battery on them.
THREE_MINUTES_S = 180.0


@dataclass(frozen=True)
class MoStatus:
    """One ``<MO status>`` value: its meaning and what to do about it."""

    code: int
    meaning: str
    retry: Retry
    min_wait_s: float = 0.0

    @property
    def success(self) -> bool:
        return self.retry is Retry.NONE

    @property
    def permanent(self) -> bool:
        return self.retry is Retry.NEVER


_KNOWN: dict[int, tuple[str, Retry, float]] = {
    0: ("MO message, if any, transferred successfully", Retry.NONE, 0.0),
    1: ("MO message, if any, transferred; the MT message queued was too big", Retry.NONE, 0.0),
    2: ("MO message, if any, transferred; the location update was not accepted", Retry.NONE, 0.0),
    10: ("gateway: the call did not complete in the allowed time", Retry.RETRY, 0.0),
    11: ("gateway: MO message queue full", Retry.WAIT, THREE_MINUTES_S),
    12: ("MO message has too many segments", Retry.NEVER, 0.0),
    13: ("gateway: the session did not complete", Retry.RETRY, 0.0),
    14: ("invalid segment size", Retry.NEVER, 0.0),
    15: ("access is denied (account or provisioning)", Retry.NEVER, 0.0),
    16: ("ISU locked: may not make SBD calls (+CULK)", Retry.NEVER, 0.0),
    17: ("gateway not responding (local session timeout)", Retry.RETRY, 0.0),
    18: ("connection lost (RF drop)", Retry.RETRY, 0.0),
    19: ("link failure (protocol error ended the call)", Retry.RETRY, 0.0),
    32: ("no network service, unable to initiate call", Retry.RETRY, 0.0),
    33: ("antenna fault, unable to initiate call", Retry.NEVER, 0.0),
    34: ("radio is disabled, unable to initiate call (*Rn)", Retry.NEVER, 0.0),
    35: ("ISU is busy, unable to initiate call", Retry.RETRY, 0.0),
    36: ("try later: must wait 3 minutes since the last registration", Retry.WAIT, THREE_MINUTES_S),
    37: ("SBD service is temporarily disabled", Retry.WAIT, THREE_MINUTES_S),
    38: ("try later: traffic management period (+SBDLOE)", Retry.WAIT, THREE_MINUTES_S),
    64: ("band violation (transmit outside the permitted band)", Retry.NEVER, 0.0),
    65: ("PLL lock failure: hardware error during transmit", Retry.NEVER, 0.0),
}


def mo_status(code: int) -> MoStatus:
    """The meaning and retry decision of an ``<MO status>``; reserved values follow the
    reference (3–4 success, the rest failure worth retrying)."""
    if code in _KNOWN:
        meaning, retry, wait = _KNOWN[code]
        return MoStatus(code, meaning, retry, wait)
    if 3 <= code <= 4:
        return MoStatus(code, "reserved, indicates success", Retry.NONE)
    return MoStatus(code, "reserved, indicates failure", Retry.RETRY)


MT_STATUS: dict[int, str] = {
    0: "no MT message to receive from the gateway",
    1: "MT message received from the gateway",
    2: "error during the mailbox check or MT reception",
}

# AT+SBDWB's result after the message and checksum (or at once for a bad length). Only 1 comes
# without a following OK (a documented quirk of the ISU).
WRITE_RESULTS: dict[int, str] = {
    0: "message written to the ISU",
    1: "write timeout: too few bytes within 60 s",
    2: "checksum mismatch",
    3: "message size not correct (1 to 340 bytes)",
}
