"""What a modem's error results mean: the +CMS ERROR (3GPP TS 27.005 §3.2.5) and +CME ERROR
(TS 27.007 §9.2) codes, numeric or verbose, and whether each is worth retrying. Pure; split from
``at.py`` (the line reader and parsers), which uses it for :class:`~.at.FinalResult`.
"""

from __future__ import annotations

# TS 27.005 §3.2.5 (+CMS ERROR) and TS 24.011/23.040 causes modems pass through; True = worth
# retrying later (network or SIM busy), False = permanent (says why, needs a person or new input).
CMS_ERRORS: dict[int, tuple[str, bool]] = {
    1: ("unassigned number", False),
    8: ("operator determined barring", False),
    10: ("call barred", False),
    21: ("short message transfer rejected", False),
    27: ("destination out of service", True),
    28: ("unidentified subscriber", False),
    29: ("facility rejected", False),
    30: ("unknown subscriber", False),
    38: ("network out of order", True),
    41: ("temporary failure", True),
    42: ("congestion", True),
    47: ("resources unavailable", True),
    50: ("requested facility not subscribed", False),
    69: ("requested facility not implemented", False),
    96: ("invalid mandatory information", False),
    111: ("protocol error", True),
    127: ("interworking unspecified", True),
    192: ("SC busy", True),
    193: ("no SC subscription", False),
    194: ("SC system failure", True),
    195: ("invalid SME address", False),
    196: ("destination SME barred", False),
    300: ("ME failure", True),
    301: ("SMS service of ME reserved", True),
    302: ("operation not allowed", False),
    303: ("operation not supported", False),
    304: ("invalid PDU mode parameter", False),
    305: ("invalid text mode parameter", False),
    310: ("SIM not inserted", False),
    311: ("SIM PIN required", False),
    312: ("PH-SIM PIN required", False),
    313: ("SIM failure", False),
    314: ("SIM busy", True),
    315: ("SIM wrong", False),
    316: ("SIM PUK required", False),
    317: ("SIM PIN2 required", False),
    318: ("SIM PUK2 required", False),
    320: ("memory failure", False),
    321: ("invalid memory index", False),
    322: ("memory full", False),
    330: ("SMSC address unknown", False),
    331: ("no network service", True),
    332: ("network timeout", True),
    340: ("no +CNMA acknowledgement expected", False),
    500: ("unknown error", True),
    512: ("SIM not ready (manufacturer)", True),
    515: ("please wait, initialising (manufacturer)", True),
}
CME_ERRORS: dict[int, tuple[str, bool]] = {
    0: ("phone failure", True),
    3: ("operation not allowed", False),
    4: ("operation not supported", False),
    10: ("SIM not inserted", False),
    11: ("SIM PIN required", False),
    12: ("SIM PUK required", False),
    13: ("SIM failure", False),
    14: ("SIM busy", True),
    15: ("SIM wrong", False),
    16: ("incorrect password", False),
    17: ("SIM PIN2 required", False),
    18: ("SIM PUK2 required", False),
    20: ("memory full", False),
    21: ("invalid index", False),
    22: ("not found", False),
    23: ("memory failure", False),
    30: ("no network service", True),
    31: ("network timeout", True),
    32: ("network not allowed, emergency calls only", False),
    100: ("unknown", True),
}
_VERBOSE: dict[str, dict[str, int]] = {
    kind: {meaning.lower(): code for code, (meaning, _temporary) in table.items()}
    for kind, table in (("+CMS ERROR", CMS_ERRORS), ("+CME ERROR", CME_ERRORS))
}


def verbose_code(kind: str, detail: str) -> int | None:
    """The code of a verbose error (``+CMS ERROR: SIM busy`` is 314), or None if unknown."""
    return _VERBOSE[kind].get(detail.lower())


def describe_error(kind: str, code: int | None, text: str = "") -> tuple[str, bool]:
    """(meaning, temporary) of a final result; unknown codes are temporary (retry, bounded)."""
    if kind == "OK":
        return "OK", False
    table = CMS_ERRORS if kind == "+CMS ERROR" else CME_ERRORS if kind == "+CME ERROR" else None
    if table is None:
        return "the modem refused the command", False
    if code in table:
        return table[code]
    detail = text.partition(":")[2].strip()
    return (detail or f"code {code}"), True
