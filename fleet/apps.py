from __future__ import annotations

from importlib import import_module

from django.apps import AppConfig, apps
from django.utils.module_loading import module_has_submodule

# django-leaflet's admin module imports GeoDjango, which needs GDAL, which this project does
# without (docs/architecture.md); the maps need the app for its template tags and assets, so admin
# autodiscovery (which would import it) is off (SimpleAdminConfig) and done here without it.
# knox's admin is for its own token model, swapped out for operators.OperatorToken.
NO_ADMIN_DISCOVERY = frozenset({"leaflet", "knox"})


class FleetConfig(AppConfig):
    name = "fleet"
    verbose_name = "Fleet"

    def ready(self) -> None:
        from fleet import checks  # noqa: F401  (registers the system checks)

        # In INSTALLED_APPS order, so fleet.admin (last) can extend the apps' own admins.
        for config in apps.get_app_configs():
            if config.name not in NO_ADMIN_DISCOVERY and module_has_submodule(
                config.module, "admin"
            ):
                import_module(f"{config.name}.admin")

        from django.contrib import admin

        from operators.login import AdminLoginForm

        admin.site.login_form = AdminLoginForm  # limits failed logins (operators/login.py)
