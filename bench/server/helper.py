"""The Django side, run in a subprocess with the stack's environment (``--_helper``)."""

from __future__ import annotations

import json


def django_helper(args: list[str]) -> None:
    """Runs inside a subprocess with the stack's environment: provision vessels, count fixes."""
    import django

    django.setup()
    from django.contrib.auth import get_user_model
    from django.db.models import Count

    from commands.services import command_enqueue
    from operators.services import operator_token_issue
    from vessels.models import Vessel
    from vessels.services import vessel_create, vessel_key_issue

    command, *rest = args
    if command == "provision":
        keys: dict[str, str] = {}
        for slug in rest:
            vessel = vessel_create(slug=slug, name=f"Bench {slug}", kind="mavlink")
            _key, keys[slug] = vessel_key_issue(vessel=vessel, label="bench")
            if slug.startswith("boat-"):
                command_enqueue(vessel=vessel, kind="hold", params={}, created_by="bench")
        user = get_user_model().objects.create_superuser("bench", "bench@example.invalid", None)
        keys["@operator-token"] = operator_token_issue(user=user, name="bench", expires_in=None)[1]
        print(json.dumps(keys))
    elif command == "count":
        rows = Vessel.objects.annotate(n=Count("fixes")).values_list("slug", "n")
        print(json.dumps(dict(rows)))
    else:
        raise SystemExit(f"unknown helper {command}")
