"""Response shapes of the map endpoints, for the OpenAPI schema only: the views write their
JSON directly (a 2,000-point track through a serializer cost more than the query)."""

from __future__ import annotations

from rest_framework import serializers


class _Geometry(serializers.Serializer):
    type = serializers.ChoiceField(choices=["MultiLineString"])
    coordinates = serializers.ListField(
        child=serializers.ListField(child=serializers.ListField(child=serializers.FloatField())),
        help_text="lines of [lon, lat] positions, 6 decimals",
    )


class _TrackProperties(serializers.Serializer):
    vessel = serializers.SlugField()
    # "from" is a keyword: declared below under its real name.
    to = serializers.DateTimeField()
    fixes = serializers.IntegerField(help_text="fixes in the range")
    points = serializers.IntegerField(help_text="distinct fixes drawn")
    gap_s = serializers.FloatField(help_text="a longer silence breaks the line")
    times = serializers.ListField(
        child=serializers.ListField(child=serializers.FloatField()),
        help_text="Unix seconds of each position, line by line",
    )


_TrackProperties._declared_fields["from"] = serializers.DateTimeField()


class _Feature(serializers.Serializer):
    type = serializers.ChoiceField(choices=["Feature"])
    geometry = _Geometry()
    properties = _TrackProperties()


class TrackSerializer(serializers.Serializer):
    type = serializers.ChoiceField(choices=["FeatureCollection"])
    features = _Feature(many=True)


class _Channel(serializers.Serializer):
    label = serializers.CharField()
    unit = serializers.CharField(allow_blank=True)
    min = serializers.ListField(child=serializers.FloatField(allow_null=True))
    max = serializers.ListField(child=serializers.FloatField(allow_null=True))
    mean = serializers.ListField(child=serializers.FloatField(allow_null=True))


class SeriesSerializer(serializers.Serializer):
    to = serializers.DateTimeField()
    bucket_s = serializers.IntegerField(help_text="bucket length, seconds")
    t = serializers.ListField(
        child=serializers.IntegerField(), help_text="bucket starts, Unix seconds"
    )
    channels = serializers.DictField(
        child=_Channel(), help_text="`battery_v`, then each reading key"
    )


SeriesSerializer._declared_fields["from"] = serializers.DateTimeField()
