"""The OpenAPI schema against the API that serves it (schemathesis).

For every operation, schemathesis sends requests built from the schema: boundary and missing
values first (its coverage phase), then random valid and deliberately invalid ones. Each answer
must be no 5xx, a status the schema documents, with the documented content type and a body that
matches its schema; invalid input must be refused and valid input accepted.

In process, through Django's WSGI handler (no server, no network) and in the test's own
transaction, so it runs on whichever database the suite runs on: the boat operations as boat A
(its vessel key), the operator operations as an operator with every right (a personal token).
The valid requests name objects that exist (boat A's slug, its command, a mission), so the
operations are reached past their 404.

SHORESIDE_SCHEMATHESIS_EXAMPLES sets the random examples per operation (default 20, about a
minute per database); raise it for a deeper local run.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from collections.abc import Iterator
from typing import Any

import pytest
import schemathesis
from django.contrib.auth.models import User
from django.core.handlers.wsgi import WSGIHandler
from django.core.signals import request_finished, request_started
from django.db import close_old_connections, connection
from django.utils import timezone
from drf_spectacular.generators import SchemaGenerator
from drf_spectacular.renderers import OpenApiJsonRenderer
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from schemathesis.specs.openapi.checks import positive_data_acceptance

from alerts.models import Alert, AlertRule, NotificationChannel
from commands.models import Command
from commands.services import command_claim_open
from edge_client.contract import compact
from operators.services import operator_token_issue
from tests.conftest import make_user
from vessels.models import Fence, Mission, Vessel
from vessels.services import mission_write

EXAMPLES = int(os.environ.get("SHORESIDE_SCHEMATHESIS_EXAMPLES", "20"))
OPERATOR_PERMS = [
    "vessels.view_vessel",
    "vessels.change_vessel",
    "vessels.view_mission",
    "vessels.add_mission",
    "vessels.change_mission",
    "vessels.delete_mission",
    "telemetry.view_fix",
    "commands.view_command",
    "commands.add_command",
    "commands.change_command",
    "audit.view_auditentry",
    *(f"alerts.{verb}_{model}" for verb in ("view", "add", "change", "delete")
      for model in ("alertrule", "alert", "notificationchannel")),
    *(f"vessels.{verb}_fence" for verb in ("view", "add", "change", "delete")),
]  # fmt: skip


def load_schema() -> dict[str, Any]:
    """The schema as /api/v1/schema/ serves it (the same generator and renderer)."""
    document = SchemaGenerator().get_schema(request=None, public=True)
    return json.loads(OpenApiJsonRenderer().render(document))


# Compact fixes are bytes schemathesis cannot make up from a schema: payloads the codec wrote
# (any bytes else are the codec's tests' business, tests/edge_client/test_compact.py).
schemathesis.openapi.media_type(
    compact.CONTENT_TYPE,
    st.lists(
        st.fixed_dictionaries({"lat": st.floats(-90, 90), "lon": st.floats(-180, 180)}),
        min_size=1,
        max_size=5,
    ).map(lambda fixes: compact.encode([{"time": "2026-11-23T10:00:00Z", **f} for f in fixes])),
)
SCHEMA = schemathesis.openapi.from_dict(load_schema())
SCHEMA.app = WSGIHandler()
PLACEHOLDER = "credentials-of-"


def _scheme(case: Any, context: Any) -> str:
    return "vesselKey" if case.operation.path.startswith("/api/v1/boat/") else "operatorToken"


@SCHEMA.auth(cache_by_key=_scheme)
class Credentials:
    """Boat A's key on the boat operations, the operator's token on the others.

    Set as schemathesis auth (not as plain headers) so that its `ignored_auth` check knows
    them for real credentials and probes each operation without them and with a wrong one.
    The keys exist only in each test's database while schemathesis builds its boundary cases
    at collection, so this sets a placeholder that the test swaps for the key.
    """

    def get(self, case: Any, context: Any) -> str:
        return PLACEHOLDER + _scheme(case, context)

    def set(self, case: Any, data: str, context: Any) -> None:
        case.headers = {**(case.headers or {}), "Authorization": data}


# The {id} of the paths under each prefix (the mission's elsewhere), set by `existing`.
ID_BY_PATH: dict[str, str] = {}


@pytest.fixture
def existing(vessel_a: Vessel, command_a: Command, reported: Vessel) -> dict[str, str]:
    """Boat A with a fix, its command handed over by a poll (so an ack can land), a mission;
    a fence, an alert rule with an open alert on boat A, a notification channel (their ids by
    path in ID_BY_PATH), so each operation is reached past its 404."""
    command_claim_open(vessel=vessel_a)
    mission = mission_write(
        mission=Mission(),
        fields={"name": "Harbour loop", "vessel": vessel_a},
        items=[{"lat": -31.95, "lon": 115.86}, {"lat": -31.96, "lon": 115.87}],
    )
    ring = [[115.86, -31.95], [115.87, -31.95], [115.87, -31.96], [115.86, -31.95]]
    fence = Fence.objects.create(
        name="Harbour", vessel=vessel_a, geometry={"type": "Polygon", "coordinates": [ring]}
    )
    rule = AlertRule.objects.create(name="Low", kind="battery", threshold=11.5)
    alert = Alert.objects.create(
        rule=rule, vessel=vessel_a, kind="battery", opened_at=timezone.now()
    )
    channel = NotificationChannel.objects.create(name="Ops", kind="email", target="o@example.org")
    for prefix, pk in (
        ("/api/v1/fences/", fence.pk),
        ("/api/v1/alert-rules/", rule.pk),
        ("/api/v1/alerts/", alert.pk),
        ("/api/v1/notification-channels/", channel.pk),
    ):
        ID_BY_PATH[prefix] = str(pk)
    return {"slug": vessel_a.slug, "uid": str(command_a.uid), "id": str(mission.pk)}


@pytest.fixture
def in_test_transaction() -> Iterator[None]:
    """Keep Django's handler from closing the test's connection around each request (as its
    test client does): the requests must see, and write into, the test's transaction."""
    request_started.disconnect(close_old_connections)
    request_finished.disconnect(close_old_connections)
    yield
    request_started.connect(close_old_connections)
    request_finished.connect(close_old_connections)


@pytest.fixture
def credentials(
    in_test_transaction: None, key_a: str, existing: dict[str, str], settings: Any
) -> dict[str, str]:
    """The Authorization header for each security scheme: boat A's key, an operator's token."""
    # Thousands of requests a minute from one key and one operator: not what this test is about.
    settings.REST_FRAMEWORK = {
        **settings.REST_FRAMEWORK,
        "DEFAULT_THROTTLE_RATES": {"boat": "100000/min", "operator": "100000/min"},
    }
    user: User = make_user("schemathesis", OPERATOR_PERMS)
    _token, raw = operator_token_issue(user=user, name="schemathesis", expires_in=None)
    return {
        PLACEHOLDER + "vesselKey": f"Api-Key {key_a}",
        PLACEHOLDER + "operatorToken": f"Token {raw}",
    }


# Rules OpenAPI 3.0 cannot state, so the valid requests follow them here: they name objects
# that exist; a time range lies within the plausible window (from 2018 to ten years ahead)
# with `from` before `to` (the audit log's `since` and `until` alike); a page's cursor is one
# the list gave (none: the first page); a mission's `updated_at` sent back is the version it
# has now; the mission starts each request without a home, so a PATCH's home rule (checked on
# the mission as it leaves it) is the body's own.
# Where validity depends on more than the request, a valid request may still be refused
# with a 400 naming why: a command's kind and params against the catalog for this vessel's
# kind, and an imported file's content.
# A fence's geometry (a closed ring of distinct vertices), an alert rule's fields by kind, a
# channel's target by kind and an imported fence file are the services' to judge, past what a
# schema can say; an alert list's `cursor` is one the list gave (any other string is a 400);
# a compact telemetry body is one the codec wrote (registered above).
VALID_BY_STATE = {
    "POST /api/v1/vessels/{slug}/commands/",
    "POST /api/v1/missions/import/",
    "POST /api/v1/fences/",
    "PATCH /api/v1/fences/{id}/",
    "POST /api/v1/fences/import/",
    "POST /api/v1/fences/{id}/send/",
    "POST /api/v1/alert-rules/",
    "PATCH /api/v1/alert-rules/{id}/",
    "POST /api/v1/notification-channels/",
    "GET /api/v1/alerts/",
}
VALID_RANGE = {"from": "2026-11-23T09:00:00Z", "to": "2026-11-23T11:00:00Z"}
VALID_TIME = "2026-11-23T10:00:00Z"


def follow_the_rules(case: Any, existing: dict[str, str]) -> None:
    """Make a valid (positive) case follow the rules above; invalid ones stay as generated."""
    if case.path_parameters:
        ids = [pk for prefix, pk in ID_BY_PATH.items() if case.path.startswith(prefix)]
        named = {**existing, **({"id": ids[0]} if ids else {})}
        case.path_parameters = {
            name: named.get(name, value) for name, value in case.path_parameters.items()
        }
    if case.query:
        query = dict(case.query)
        for name, same in (("from", "from"), ("to", "to"), ("since", "from"), ("until", "to")):
            if name in query:
                query[name] = VALID_RANGE[same]
        if "time" in query:
            query["time"] = VALID_TIME
        query.pop("cursor", None)
        case.query = query
    if isinstance(case.body, dict) and isinstance(case.body.get("vessel"), str):
        case.body = {**case.body, "vessel": existing["slug"]}
    if isinstance(case.body, dict) and "updated_at" in case.body:
        mission = Mission.objects.get(pk=existing["id"])
        case.body = {**case.body, "updated_at": mission.updated_at.isoformat()}


# What the run did, printed once at the end of the module (CI's log then carries the figures
# per database): operations reached, requests made by the cases, answers by status class.
TALLY: Counter[str] = Counter()
OPERATIONS: set[str] = set()


@pytest.fixture(scope="module", autouse=True)
def report_the_tally(request: pytest.FixtureRequest) -> Iterator[None]:
    yield
    if not TALLY:
        return
    classes = ", ".join(f"{k} {TALLY[k]}" for k in sorted(TALLY) if k.endswith("xx"))
    line = (
        f"schemathesis on {connection.vendor}: {len(OPERATIONS)} operations, "
        f"{TALLY['requests']} requests ({classes}), {EXAMPLES} random examples per operation"
    )
    reporter = request.config.pluginmanager.get_plugin("terminalreporter")
    capture = request.config.pluginmanager.get_plugin("capturemanager")
    if reporter is not None and capture is not None:
        # A fixture's teardown runs under pytest's output capture: lift it for the line.
        with capture.global_and_fixture_disabled():
            reporter.ensure_newline()
            reporter.write_line(line)


@pytest.mark.slow
@pytest.mark.django_db
@SCHEMA.parametrize()
@settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=list(HealthCheck),
)
def test_the_api_answers_as_its_schema_says(
    case: Any, credentials: dict[str, str], existing: dict[str, str]
) -> None:
    if case.meta.generation.mode.is_positive:
        follow_the_rules(case, existing)
    Mission.objects.filter(pk=existing["id"]).update(home_lat=None, home_lon=None)
    placeholder = (case.headers or {}).get("Authorization")
    if placeholder in credentials:
        case.headers["Authorization"] = credentials[placeholder]
    excluded = [positive_data_acceptance] if case.operation.label in VALID_BY_STATE else []
    response = case.call_and_validate(excluded_checks=excluded)
    OPERATIONS.add(case.operation.label)
    TALLY["requests"] += 1
    TALLY[f"{response.status_code // 100}xx"] += 1
