"""Each service that does an audited thing writes its entry, whichever way it was called: who
(an operator, a phone, the shell user), through what (admin, api, map, sms, cli) and from
where (the client's address, by the TRUSTED_PROXIES rule). A boat's own requests write none."""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.contrib.auth.models import User
from django.core.management import call_command
from django.test import Client
from rest_framework.test import APIClient

from audit.models import AuditEntry
from commands.models import Command
from operators.models import OperatorToken
from sms.models import AuthorisedNumber
from sms.services import authorised_number_authorise, sms_handle_incoming
from tests.conftest import give_position
from tests.support import BASE, COMMANDS, TELEMETRY, ack_url, cancel_url, commands_url, iso
from vessels.models import Mission, Vessel, VesselKey
from vessels.services import mission_write

OFFICE = "198.51.100.10"
SKIPPER = "+61412345678"


def only(action: str) -> AuditEntry:
    return AuditEntry.objects.get(action=action)


def who_how_where(entry: AuditEntry) -> tuple[str, str, str, str | None]:
    return entry.actor, entry.actor_kind, entry.via, entry.ip


# --- commands ---------------------------------------------------------------------------------


def test_a_command_queued_through_the_api_names_the_operator_and_address(
    token_operator: APIClient, vessel_a: Vessel
) -> None:
    response = token_operator.post(
        commands_url(), {"kind": "hold", "params": {}}, format="json", REMOTE_ADDR=OFFICE
    )
    assert response.status_code == 201
    entry = only("command.queued")
    assert who_how_where(entry) == ("alice", "operator", "api", OFFICE)
    assert (entry.subject_type, entry.subject_id) == ("command", response.json()["uid"])
    assert (entry.subject, entry.vessel) == ("hold → SPAB", "spab")
    assert entry.detail == {"kind": "hold", "params": {}}


def test_a_command_from_the_fleet_map_says_map(
    session_operator: APIClient, vessel_a: Vessel
) -> None:
    give_position(vessel_a)
    params = {"lat": -31.95, "lon": 115.86}
    response = session_operator.post(
        commands_url(), {"kind": "move_to", "params": params, "source": "map"}, format="json"
    )
    assert response.status_code == 201
    entry = only("command.queued")
    assert who_how_where(entry) == ("alice", "operator", "map", "127.0.0.1")
    assert entry.detail == {"kind": "move_to", "params": params}


def test_a_command_queued_in_the_admin_says_admin(admin_ui: Client, vessel_a: Vessel) -> None:
    response = admin_ui.post(
        "/admin/commands/command/add/",
        {"vessel": vessel_a.pk, "kind": "hold", "expires_at": ""},
        REMOTE_ADDR=OFFICE,
    )
    assert response.status_code == 302, response.content.decode()[:3000]
    assert who_how_where(only("command.queued")) == ("admin", "operator", "admin", OFFICE)


def test_a_command_by_sms_names_the_phone_and_no_address(glider: Vessel) -> None:
    authorised_number_authorise(number=SKIPPER, vessels=[glider], role="control", name="Skipper")
    sms_handle_incoming(
        vessel=glider, number=SKIPPER, text="#FHEAD 230", received_at=BASE, modem_timestamp=BASE
    )
    entry = only("command.queued")
    assert who_how_where(entry) == (SKIPPER, "phone", "sms", None)
    assert entry.detail == {"kind": "fhead", "params": {"bearing": 230}}


def test_a_refused_command_writes_no_entry(token_operator: APIClient, vessel_a: Vessel) -> None:
    response = token_operator.post(
        commands_url(), {"kind": "fhead", "params": {"bearing": 230}}, format="json"
    )
    assert response.status_code == 400  # a heading is for gliders
    assert not AuditEntry.objects.filter(action__startswith="command.").exists()


def test_a_cancel_names_who_cancelled_and_what_it_was(
    token_operator: APIClient, command_a: Command
) -> None:
    response = token_operator.post(cancel_url(command_a.uid), REMOTE_ADDR=OFFICE)
    assert response.status_code == 200
    entry = only("command.cancelled")
    assert who_how_where(entry) == ("alice", "operator", "api", OFFICE)
    assert (entry.subject_id, entry.vessel) == (str(command_a.uid), "spab")
    assert entry.detail == {"kind": "move_to", "was": "queued"}


def test_a_refused_cancel_writes_no_entry(token_operator: APIClient, command_a: Command) -> None:
    token_operator.post(cancel_url(command_a.uid))
    assert token_operator.post(cancel_url(command_a.uid)).status_code == 409
    assert AuditEntry.objects.filter(action="command.cancelled").count() == 1


def test_a_mission_sent_is_one_entry_naming_the_mission_and_its_command(
    operator_user: User, vessel_a: Vessel
) -> None:
    mission = mission_write(
        mission=Mission(),
        fields={"name": "Harbour loop", "vessel": vessel_a},
        items=[{"lat": -31.95, "lon": 115.86}, {"lat": -31.96, "lon": 115.87}],
    )
    operator_user.user_permissions.add(*perms("vessels.view_mission"))
    client = APIClient()
    client.force_authenticate(User.objects.get(pk=operator_user.pk))
    response = client.post(f"/api/v1/missions/{mission.pk}/send/", {}, format="json")
    assert response.status_code == 201, response.json()
    entry = AuditEntry.objects.get()
    assert entry.action == "mission.sent"
    assert (entry.subject_type, entry.subject_id) == ("mission", str(mission.pk))
    assert (entry.subject, entry.vessel, entry.via) == ("Harbour loop → SPAB", "spab", "api")
    assert entry.detail == {
        "command": response.json()["uid"], "mission": "Harbour loop", "waypoints": 2,
    }  # fmt: skip


def perms(*names: str) -> list[Any]:
    from django.contrib.auth.models import Permission

    found = []
    for name in names:
        app, codename = name.split(".")
        found.append(Permission.objects.get(content_type__app_label=app, codename=codename))
    return found


# --- vessel keys --------------------------------------------------------------------------------


def test_a_key_issued_and_revoked_in_the_admin(admin_ui: Client, vessel_a: Vessel) -> None:
    admin_ui.post(
        "/admin/vessels/vesselkey/add/", {"vessel": vessel_a.pk, "label": "pi"}, REMOTE_ADDR=OFFICE
    )
    key = VesselKey.objects.get()
    admin_ui.post("/admin/vessels/vesselkey/", {"action": "revoke", "_selected_action": [key.pk]})
    issued, revoked = only("key.issued"), only("key.revoked")
    assert who_how_where(issued) == ("admin", "operator", "admin", OFFICE)
    assert who_how_where(revoked) == ("admin", "operator", "admin", "127.0.0.1")
    for entry in (issued, revoked):
        assert (entry.subject_type, entry.subject_id, entry.vessel) == (
            "vessel key", str(key.pk), "spab",
        )  # fmt: skip
        assert entry.detail == {"prefix": key.prefix, "label": "pi"}
    assert key.key_hash not in str(list(AuditEntry.objects.values()))


def test_revoking_a_revoked_key_again_is_not_logged_again(admin_ui: Client, key_a: str) -> None:
    key = VesselKey.objects.get()
    for _ in range(2):
        admin_ui.post(
            "/admin/vessels/vesselkey/", {"action": "revoke", "_selected_action": [key.pk]}
        )
    assert AuditEntry.objects.filter(action="key.revoked").count() == 1


def test_keys_from_the_shell_name_the_shell_user(vessel_a: Vessel, capsys: Any) -> None:
    call_command("issue_key", "spab", "--label", "pi")
    prefix = VesselKey.objects.get().prefix
    call_command("revoke_key", "spab", prefix)
    for action in ("key.issued", "key.revoked"):
        actor, kind, via, ip = who_how_where(only(action))
        assert (actor.endswith("(manage.py)"), kind, via, ip) == (True, "system", "cli", None)
    # The key's own record names the same person.
    assert VesselKey.objects.get().created_by == only("key.issued").actor


# --- operators' API tokens ----------------------------------------------------------------------


def test_a_token_issued_for_someone_else_names_both(admin_ui: Client, operator_user: User) -> None:
    response = admin_ui.post(
        "/admin/operators/operatortoken/add/",
        {"user": operator_user.pk, "name": "alice's laptop", "expires_days": 30},
        REMOTE_ADDR=OFFICE,
    )
    assert response.status_code == 200
    token = OperatorToken.objects.get()
    entry = only("token.issued")
    assert who_how_where(entry) == ("admin", "operator", "admin", OFFICE)
    assert (entry.subject_type, entry.subject_id) == ("api token", str(token.pk))
    assert entry.subject == f"alice's laptop ({token.token_key}…) of alice"
    assert entry.detail["owner"] == "alice" and entry.detail["expiry"] == token.expiry.isoformat()
    assert token.digest not in str(list(AuditEntry.objects.values()))


def test_a_revoked_token_is_gone_and_its_entry_stays(admin_ui: Client, operator_user: User) -> None:
    admin_ui.post(
        "/admin/operators/operatortoken/add/",
        {"user": operator_user.pk, "name": "old script", "expires_days": 0},
    )
    token = OperatorToken.objects.get()
    admin_ui.post(
        "/admin/operators/operatortoken/",
        {"action": "revoke", "_selected_action": [token.pk]},
    )
    assert not OperatorToken.objects.exists()
    entry = only("token.revoked")
    assert (entry.actor, entry.via, entry.subject_id) == ("admin", "admin", str(token.pk))
    assert entry.detail == {"owner": "alice", "name": "old script", "expiry": None}


def test_a_token_from_the_shell_names_the_shell_user(operator_user: User, capsys: Any) -> None:
    call_command("issue_token", "alice", "--name", "cron")
    entry = only("token.issued")
    assert (entry.actor_kind, entry.via, entry.detail["owner"]) == ("system", "cli", "alice")


# --- authorised numbers -------------------------------------------------------------------------


def number_form(glider: Vessel, **changes: Any) -> dict[str, Any]:
    return {
        "number": "0412 345 678", "name": "Skipper", "vessels": [glider.pk], "role": "control",
        "active": "on", "notes": "", **changes,
    }  # fmt: skip


def test_numbers_added_changed_and_removed_in_the_admin(admin_ui: Client, glider: Vessel) -> None:
    admin_ui.post("/admin/sms/authorisednumber/add/", number_form(glider), REMOTE_ADDR=OFFICE)
    entry = AuthorisedNumber.objects.get()
    change = f"/admin/sms/authorisednumber/{entry.pk}/change/"
    admin_ui.post(change, number_form(glider, role="query", notes="night watch"))
    admin_ui.post(change, number_form(glider, role="query", notes="night watch"))  # no change
    admin_ui.post(f"/admin/sms/authorisednumber/{entry.pk}/delete/", {"post": "yes"})
    assert not AuthorisedNumber.objects.exists()

    added, changed, removed = (
        only(a) for a in ("number.added", "number.changed", "number.removed")
    )
    assert who_how_where(added) == ("admin", "operator", "admin", OFFICE)
    assert (added.subject, added.vessel) == (f"Skipper ({SKIPPER})", "glider")
    assert added.detail == {
        "number": SKIPPER, "name": "Skipper", "role": "control", "active": True,
        "expires_at": None, "receives_positions": False, "notes": "", "vessels": ["glider"],
    }  # fmt: skip
    assert changed.detail == {"changes": {"role": ["control", "query"], "notes": ["", "set"]}}
    assert removed.detail["role"] == "query" and removed.subject_id == str(entry.pk)
    assert AuditEntry.objects.filter(action__startswith="number.").count() == 3


def test_deauthorising_is_logged_once(admin_ui: Client, glider: Vessel) -> None:
    entry = authorised_number_authorise(
        number=SKIPPER, vessels=[glider], role="control", name="Skipper"
    )
    for _ in range(2):
        admin_ui.post(
            "/admin/sms/authorisednumber/",
            {"action": "deauthorise", "_selected_action": [entry.pk]},
        )
    deauthorised = only("number.deauthorised")
    assert (deauthorised.actor, deauthorised.via, deauthorised.vessel) == (
        "admin", "admin", "glider",
    )  # fmt: skip


def test_numbers_from_the_shell_and_a_rerun_that_changes_nothing(
    glider: Vessel, vessel_a: Vessel, capsys: Any
) -> None:
    args = ["authorise_number", SKIPPER, "--vessel", "glider", "--role", "control"]
    call_command(*args, "--name", "Skipper")
    call_command(*args, "--name", "Skipper")  # provisioning is idempotent: nothing changed
    call_command(*args, "--name", "Skipper", "--vessel", "spab")
    call_command("deauthorise_number", SKIPPER)
    actions = list(AuditEntry.objects.order_by("pk").values_list("action", "via", "actor_kind"))
    assert actions == [
        ("number.added", "cli", "system"),
        ("number.changed", "cli", "system"),
        ("number.deauthorised", "cli", "system"),
    ]
    changed = only("number.changed")
    assert changed.detail == {"changes": {"vessels": [["glider"], ["glider", "spab"]]}}
    assert changed.vessel == ""  # two vessels: the detail names them


# --- logins -----------------------------------------------------------------------------------


def admin_login(username: str, password: str) -> Any:
    return Client().post(
        "/admin/login/",
        {"username": username, "password": password, "next": "/admin/"},
        REMOTE_ADDR=OFFICE,
    )


def test_logins_failed_logins_and_logouts(operator_user: User) -> None:
    assert admin_login("alice", "guess").status_code == 200
    response = admin_login("alice", "pw-alice")
    assert response.status_code == 302
    client = response.client
    client.post("/admin/logout/", REMOTE_ADDR=OFFICE)
    actions = list(AuditEntry.objects.order_by("pk").values_list("action", "actor", "via", "ip"))
    assert actions == [
        ("login.failed", "alice", "admin", OFFICE),
        ("login.succeeded", "alice", "admin", OFFICE),
        ("login.logged_out", "alice", "admin", OFFICE),
    ]


def test_a_failed_login_for_no_such_user_names_the_name_tried(db: None) -> None:
    admin_login("mallory", "hunter2")
    entry = only("login.failed")
    assert (entry.actor, entry.subject) == ("mallory", "mallory")
    assert "hunter2" not in str(list(AuditEntry.objects.values()))


def test_a_login_refused_for_too_many_failures_says_throttled(
    operator_user: User, settings: Any
) -> None:
    for _ in range(settings.LOGIN_FAILURE_LIMIT):
        admin_login("alice", "guess")
    admin_login("alice", "pw-alice")
    assert AuditEntry.objects.filter(action="login.failed").count() == settings.LOGIN_FAILURE_LIMIT
    assert who_how_where(only("login.throttled")) == ("alice", "operator", "admin", OFFICE)
    assert not AuditEntry.objects.filter(action="login.succeeded").exists()


def test_the_address_behind_a_trusted_proxy_is_the_clients(
    operator_user: User, settings: Any
) -> None:
    settings.TRUSTED_PROXIES = ["127.0.0.1"]
    Client().post(
        "/admin/login/", {"username": "alice", "password": "guess"},
        REMOTE_ADDR="127.0.0.1", HTTP_X_FORWARDED_FOR=f"{OFFICE}, 127.0.0.1",
    )  # fmt: skip
    assert only("login.failed").ip == OFFICE


def test_a_forged_forwarded_for_is_not_believed(operator_user: User, settings: Any) -> None:
    settings.TRUSTED_PROXIES = []
    Client().post(
        "/admin/login/", {"username": "alice", "password": "guess"},
        REMOTE_ADDR="203.0.113.66", HTTP_X_FORWARDED_FOR=OFFICE,
    )  # fmt: skip
    assert only("login.failed").ip == "203.0.113.66"


# --- on a glider: what its shore sends ----------------------------------------------------------


def test_on_a_glider_the_shores_commands_and_numbers_name_the_shore(
    glider: Vessel, tmp_path: Any
) -> None:
    from sms.bridge.shore import ShoreLink
    from sms.bridge.shore_config import ShoreConfig
    from sms.services import authorised_numbers_replace
    from tests.sms.bridge.test_shore_units import ListingShore

    authorised_numbers_replace(
        vessel=glider,
        numbers=[{"number": SKIPPER, "name": "Ana", "role": "control", "active": True}],
    )
    authorised_numbers_replace(vessel=glider, numbers=[])  # Ana may no longer text it
    shore = ListingShore()
    shore.open = [{"uid": "6f1c2d3e-0000-4000-8000-000000000001", "kind": "light",
                   "params": {"state": "on"}}]  # fmt: skip
    config = ShoreConfig(url="http://127.0.0.1:9", key="k", outbox_path=str(tmp_path / "o.db"))
    link = ShoreLink(vessel=glider, config=config, transport=shore)
    try:
        assert link.do_one_poll_commands() is True
    finally:
        link.close()
    entries = AuditEntry.objects.order_by("pk").values_list("action", "actor", "actor_kind", "via")
    assert list(entries) == [
        ("number.added", "shore", "system", "shore"),
        ("number.changed", "shore", "system", "shore"),
        ("command.queued", "shore", "system", "api"),
    ]
    changed = only("number.changed")
    assert changed.detail == {"changes": {"vessels": [["glider"], []]}}


# --- the boat's own requests are not audit events -----------------------------------------------


def test_a_boats_fix_posts_polls_and_acks_write_no_entry(
    boat_a: APIClient, command_a: Command, make_fix: Any
) -> None:
    before = AuditEntry.objects.count()  # the fixtures' key issue and command
    fixes = [make_fix(time=iso(BASE + dt.timedelta(hours=1, seconds=s))) for s in range(2)]
    assert boat_a.post(TELEMETRY, fixes[:1], format="json").json()["accepted"] == 1
    assert boat_a.post(TELEMETRY, {"fixes": fixes}, format="json").json()["accepted"] == 1
    assert boat_a.get(COMMANDS).status_code == 200
    ack = boat_a.post(ack_url(command_a.uid), {"status": "acknowledged"}, format="json")
    assert ack.status_code == 200
    assert AuditEntry.objects.count() == before
