from django.apps import AppConfig


class SbdConfig(AppConfig):
    name = "sbd"
    verbose_name = "Iridium SBD"
