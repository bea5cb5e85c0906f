"""What the server's batch uploads share beyond the answer itself (which is the contract's,
``edge_client.contract.batch.BatchAnswer``): an entry the API could not read."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Unreadable:
    """An entry of a batch the API could not read (not an object, a field of the wrong type),
    with the errors to answer for it: the service still counts it, by its index."""

    errors: Mapping[str, Any]
