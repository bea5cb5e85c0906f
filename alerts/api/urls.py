"""Operator API for alerts and fences, under /api/v1/ (docs/api.md)."""

from __future__ import annotations

from django.urls import path
from rest_framework.routers import DefaultRouter

from alerts.api.fences import FenceSendView, FenceViewSet
from alerts.api.views import AlertRuleViewSet, AlertViewSet, ChannelViewSet

router = DefaultRouter(trailing_slash=True)
router.include_root_view = False
router.register("alert-rules", AlertRuleViewSet, basename="alert-rule")
router.register("alerts", AlertViewSet, basename="alert")
router.register("fences", FenceViewSet, basename="fence")
router.register("notification-channels", ChannelViewSet, basename="notification-channel")

urlpatterns = [
    path("fences/<int:pk>/send/", FenceSendView.as_view(), name="fence-send"),
    *router.urls,
]
