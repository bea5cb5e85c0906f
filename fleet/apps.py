from __future__ import annotations

from importlib import import_module

from django.apps import AppConfig

# Apps whose admin.py registers models (see the SimpleAdminConfig note in settings).
ADMIN_APPS = (
    "django.contrib.auth",  # users and groups (operators)
    "operators",  # operators' personal API tokens
    "vessels",
    "telemetry",
    "commands",
)


class FleetConfig(AppConfig):
    name = "fleet"
    verbose_name = "Fleet"

    def ready(self) -> None:
        from fleet import checks  # noqa: F401  (registers the system checks)

        for app in ADMIN_APPS:
            import_module(f"{app}.admin")

        from django.contrib import admin

        from operators.login import AdminLoginForm

        admin.site.login_form = AdminLoginForm  # limits failed logins (operators/login.py)
