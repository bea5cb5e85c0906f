from django.apps import AppConfig


class OperatorsConfig(AppConfig):
    name = "operators"
    verbose_name = "Operators"

    def ready(self) -> None:
        from django.contrib.auth import signals

        from operators import login

        # Logins, failed logins and logouts in the audit log (why signals: operators.login).
        signals.user_logged_in.connect(login.audit_logged_in, dispatch_uid="audit-login")
        signals.user_login_failed.connect(login.audit_login_failed, dispatch_uid="audit-fail")
        signals.user_logged_out.connect(login.audit_logged_out, dispatch_uid="audit-logout")
