"""Serializer fields the operator API shares: JSON types taken as the schema states them."""

from __future__ import annotations

from typing import Any

from rest_framework import serializers


class StrictFloatField(serializers.FloatField):
    """A FloatField that takes only a JSON number: DRF's takes "1.5" and true as well."""

    def to_internal_value(self, data: Any) -> float:
        if isinstance(data, bool) or not isinstance(data, int | float):
            self.fail("invalid")
        return super().to_internal_value(data)


class StrictCharField(serializers.CharField):
    """A CharField that takes only a JSON string.

    DRF's turns a number into its text (`"name": 0` is stored as "0"), so a client's bug
    (a number where the schema says string) would pass unseen: here it is a 400.
    """

    def to_internal_value(self, data: Any) -> str:
        if not isinstance(data, str):
            self.fail("invalid")
        return super().to_internal_value(data)
