from django.apps import AppConfig


class VesselsConfig(AppConfig):
    name = "vessels"
