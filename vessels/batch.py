"""The answer a boat's batch upload gets: ``{"accepted": n, "duplicates": n, "rejected":
[{"index": i, "errors": {...}}]}``. The command report and the SMS log build it here; the
telemetry upload's IngestResult has the same shape."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Unreadable:
    """An entry of a batch the API could not read (not an object, a field of the wrong type),
    with the errors to answer for it: the service still counts it, by its index."""

    errors: Mapping[str, Any]


@dataclass
class BatchAnswer:
    accepted: int = 0
    duplicates: int = 0
    rejected: list[dict[str, Any]] = field(default_factory=list)

    def reject(self, index: int, errors: Mapping[str, Any]) -> None:
        self.rejected.append({"index": index, "errors": dict(errors)})

    def as_dict(self) -> dict[str, Any]:
        return {"accepted": self.accepted, "duplicates": self.duplicates, "rejected": self.rejected}
