"""Serializer fields the operator API shares: JSON types taken as the schema states them."""

from __future__ import annotations

from typing import Any

from drf_spectacular.extensions import OpenApiSerializerFieldExtension
from rest_framework import serializers

# DRF's CharField refuses a NUL (ProhibitNullCharactersValidator: no database text holds one)
# and, unless blank is allowed, a value that is only whitespace (it trims before checking).
# Where blank is allowed, drf-spectacular adds "" as a second `oneOf` choice to a pattern: so
# the pattern leaves "" out (`oneOf` takes a value matching exactly one).
NO_NUL = "^[^\\u0000]+$"
NOT_BLANK_NO_NUL = "^(?=[\\s\\S]*\\S)[^\\u0000]*$"


class StrictFloatField(serializers.FloatField):
    """A FloatField that takes only a JSON number: DRF's takes "1.5" and true as well."""

    def to_internal_value(self, data: Any) -> float:
        if isinstance(data, bool) or not isinstance(data, int | float):
            self.fail("invalid")
        return super().to_internal_value(data)


class StrictBooleanField(serializers.BooleanField):
    """A BooleanField that takes only JSON true or false: DRF's takes "yes", 1 and "on"."""

    def to_internal_value(self, data: Any) -> bool:
        if not isinstance(data, bool):
            self.fail("invalid")
        return data


class StrictCharField(serializers.CharField):
    """A CharField that takes only a JSON string.

    DRF's turns a number into its text (`"name": 0` is stored as "0"), so a client's bug
    (a number where the schema says string) would pass unseen: here it is a 400.
    """

    def to_internal_value(self, data: Any) -> str:
        if not isinstance(data, str):
            self.fail("invalid")
        return super().to_internal_value(data)


class StrictCharFieldSchema(OpenApiSerializerFieldExtension):
    """The field's schema says what the field refuses: a NUL, and all-whitespace unless blank
    is allowed."""

    target_class = StrictCharField

    def map_serializer_field(self, auto_schema: Any, direction: str) -> dict[str, Any]:
        schema = auto_schema._map_serializer_field(self.target, direction, bypass_extensions=True)
        pattern = NO_NUL if self.target.allow_blank else NOT_BLANK_NO_NUL
        return {**schema, "pattern": pattern}
