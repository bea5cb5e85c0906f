"""Operator API for the audit log, under /api/v1/."""

from __future__ import annotations

from django.urls import path

from audit.api.views import AuditEntryList

urlpatterns = [path("audit/", AuditEntryList.as_view(), name="audit")]
