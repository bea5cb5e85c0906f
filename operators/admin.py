"""Operators manage their own API tokens here; superusers see everyone's.

A token is a personal credential with the powers of its owner, so, like changing one's own
password, managing one's own tokens needs no model permission: any active staff user may.
"""

from __future__ import annotations

from datetime import timedelta
from typing import Any

from django import forms
from django.contrib import admin, messages
from django.db.models import QuerySet
from django.http import HttpRequest, HttpResponse
from django.template.response import TemplateResponse
from django.utils import formats, timezone
from django.utils.timezone import localtime

from operators.models import OperatorToken
from operators.services import operator_token_issue, operator_token_revoke

DEFAULT_EXPIRES_DAYS = 90


class TokenAddForm(forms.ModelForm):
    expires_days = forms.IntegerField(
        label="Expires in (days)",
        min_value=0,
        initial=DEFAULT_EXPIRES_DAYS,
        help_text="0 = never.",
    )

    class Meta:
        model = OperatorToken
        fields = ["name"]

    def clean(self) -> dict[str, Any]:
        cleaned = super().clean()
        user = cleaned.get("user")
        if user is not None and not user.is_active:
            self.add_error("user", f"{user.get_username()} is not an active user.")
        return cleaned


@admin.register(OperatorToken)
class OperatorTokenAdmin(admin.ModelAdmin):
    # Never the digest: name, the non-secret first characters, dates.
    list_display = ["name", "user", "prefix", "created", "expires", "state"]
    list_select_related = ["user"]
    search_fields = ["name", "token_key"]
    raw_id_fields = ["user"]
    actions = ["revoke"]

    def get_queryset(self, request: HttpRequest) -> QuerySet[OperatorToken]:
        tokens = super().get_queryset(request)
        return tokens if request.user.is_superuser else tokens.filter(user=request.user)

    def _own(self, request: HttpRequest, token: OperatorToken | None) -> bool:
        user = request.user
        if not (user.is_active and user.is_staff):
            return False
        return token is None or user.is_superuser or token.user_id == user.pk

    def has_module_permission(self, request: HttpRequest) -> bool:
        return self._own(request, None)

    def has_view_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return self._own(request, obj)

    def has_add_permission(self, request: HttpRequest) -> bool:
        return self._own(request, None)

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False  # issued and revoked, never edited

    def has_delete_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return self._own(request, obj)

    def get_actions(self, request: HttpRequest) -> dict[str, Any]:
        actions = super().get_actions(request)
        actions.pop("delete_selected", None)  # "Revoke selected tokens" says what it does
        return actions

    def get_fields(self, request: HttpRequest, obj: OperatorToken | None = None) -> list[str]:
        if obj is None:
            mine = ["name", "expires_days"]
            return ["user", *mine] if request.user.is_superuser else mine
        return ["name", "user", "prefix", "created", "expiry", "state"]

    def get_readonly_fields(self, request: HttpRequest, obj: OperatorToken | None = None) -> Any:
        return self.get_fields(request, obj) if obj else []

    def get_form(self, request: HttpRequest, obj: Any = None, change: bool = False, **kwargs: Any):
        if obj is None:
            kwargs["form"] = TokenAddForm
        return super().get_form(request, obj, change, **kwargs)

    def get_changeform_initial_data(self, request: HttpRequest) -> dict[str, Any]:
        return {"user": request.user.pk, **super().get_changeform_initial_data(request)}

    def save_model(self, request: HttpRequest, obj: OperatorToken, form: Any, change: bool) -> None:
        days = form.cleaned_data["expires_days"]
        token, raw = operator_token_issue(
            user=form.cleaned_data.get("user") or request.user,
            name=obj.name,
            expires_in=timedelta(days=days) if days else None,
        )
        obj.pk, obj.user, obj.digest, obj.token_key, obj.created, obj.expiry = (
            token.pk,
            token.user,
            token.digest,
            token.token_key,
            token.created,
            token.expiry,
        )
        request._issued_token = raw  # shown once by response_add, never stored

    def response_add(
        self, request: HttpRequest, obj: OperatorToken, post_url_continue: Any = None
    ) -> HttpResponse:
        context = {
            **self.admin_site.each_context(request),
            "token": obj,
            "raw_token": request._issued_token,
        }
        response = TemplateResponse(request, "operators/token_issued.html", context)
        response["Cache-Control"] = "no-store"
        return response

    def delete_model(self, request: HttpRequest, obj: OperatorToken) -> None:
        operator_token_revoke(token=obj)

    def delete_queryset(self, request: HttpRequest, queryset: QuerySet[OperatorToken]) -> None:
        for token in queryset:
            operator_token_revoke(token=token)

    @admin.action(description="Revoke selected tokens", permissions=["delete"])
    def revoke(self, request: HttpRequest, queryset: QuerySet[OperatorToken]) -> None:
        count = 0
        for token in queryset:
            operator_token_revoke(token=token)
            count += 1
        messages.success(request, f"Revoked {count} token(s).")

    @admin.display(description="prefix", ordering="token_key")
    def prefix(self, token: OperatorToken) -> str:
        return f"{token.token_key}…"

    @admin.display(description="expires", ordering="expiry")
    def expires(self, token: OperatorToken) -> str:
        return "never" if token.expiry is None else formats.localize(localtime(token.expiry))

    @admin.display(description="state")
    def state(self, token: OperatorToken) -> str:
        return "expired" if token.is_expired(timezone.now()) else "active"
