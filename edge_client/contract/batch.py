"""The answer to a boat's batch upload (fixes, command reports, the SMS log), docs/api.md:
``{"accepted": n, "duplicates": n, "rejected": [{"index": i, "errors": {...}}]}``.

The server builds it with :class:`BatchAnswer`; the boat settles its outbox by it
(``edge_client.outbox.settle_fix_batch``): every entry of the batch is accounted for once.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

KEYS = ("accepted", "duplicates", "rejected")


@dataclass
class BatchAnswer:
    accepted: int = 0
    duplicates: int = 0
    rejected: list[dict[str, Any]] = field(default_factory=list)

    def reject(self, index: int, errors: Mapping[str, Any]) -> None:
        self.rejected.append({"index": index, "errors": dict(errors)})

    def as_dict(self) -> dict[str, Any]:
        return {"accepted": self.accepted, "duplicates": self.duplicates, "rejected": self.rejected}
