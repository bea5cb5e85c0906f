"""The token admin: the raw token shown once, never the digest; each operator sees and revokes
only their own tokens, a superuser everyone's."""

from __future__ import annotations

import re
from datetime import timedelta

import pytest
from django.contrib.auth.models import User
from django.test import Client
from knox.crypto import hash_token

from operators.models import OperatorToken
from operators.services import operator_token_issue

CHANGELIST = "/admin/operators/operatortoken/"


@pytest.fixture
def alice_ui(operator_user: User) -> Client:
    client = Client()
    client.force_login(operator_user)
    return client


@pytest.fixture
def bobs_token(readonly_user: User) -> OperatorToken:
    return operator_token_issue(user=readonly_user, name="bob's phone", expires_in=None)[0]


def test_adding_a_token_shows_it_once(alice_ui: Client, operator_user: User) -> None:
    response = alice_ui.post(CHANGELIST + "add/", {"name": "ops laptop", "expires_days": "30"})
    assert response.status_code == 200
    assert "no-store" in response["Cache-Control"]
    raw = re.search(r'<code id="api-token"[^>]*>([^<]+)</code>', response.content.decode())[1]
    token = OperatorToken.objects.get()
    assert (token.user, token.name, token.digest) == (operator_user, "ops laptop", hash_token(raw))
    assert token.expiry - token.created == pytest.approx(
        timedelta(days=30), abs=timedelta(seconds=5)
    )
    # Never again: neither the list nor the token's own page has it.
    for url in (CHANGELIST, f"{CHANGELIST}{token.pk}/change/"):
        page = alice_ui.get(url)
        assert page.status_code == 200
        assert raw not in page.content.decode()


def test_the_list_shows_name_prefix_and_dates_never_the_digest(
    alice_ui: Client, operator_user: User
) -> None:
    token, raw = operator_token_issue(
        user=operator_user, name="ops laptop", expires_in=timedelta(days=3)
    )
    for url in (CHANGELIST, f"{CHANGELIST}{token.pk}/change/"):
        html = alice_ui.get(url).content.decode()
        assert "ops laptop" in html and token.token_key in html
        assert token.digest not in html
        assert raw not in html
    assert "active" in alice_ui.get(CHANGELIST).content.decode()


def test_an_operator_needs_no_model_permission_for_their_own_tokens(
    client: Client, readonly_user: User
) -> None:
    client.force_login(readonly_user)  # bob: staff, no permissions at all
    assert CHANGELIST in client.get("/admin/").content.decode()
    assert (
        client.post(CHANGELIST + "add/", {"name": "bob's", "expires_days": "0"}).status_code == 200
    )
    assert OperatorToken.objects.get().user == readonly_user
    assert OperatorToken.objects.get().expiry is None
    assert "never" in client.get(CHANGELIST).content.decode()


def test_an_operator_sees_only_their_own_tokens(
    alice_ui: Client, operator_user: User, bobs_token: OperatorToken
) -> None:
    mine, _ = operator_token_issue(user=operator_user, name="alice's laptop", expires_in=None)
    html = alice_ui.get(CHANGELIST).content.decode()
    assert "alice&#x27;s laptop" in html and "bob&#x27;s phone" not in html
    response = alice_ui.get(f"{CHANGELIST}{bobs_token.pk}/change/")
    assert response.status_code == 302  # "doesn't exist", like any object outside the queryset
    assert alice_ui.get(f"{CHANGELIST}{mine.pk}/change/").status_code == 200


def test_an_operator_cannot_revoke_someone_elses_token(
    alice_ui: Client, operator_user: User, bobs_token: OperatorToken
) -> None:
    mine, _ = operator_token_issue(user=operator_user, name="alice's laptop", expires_in=None)
    alice_ui.post(
        CHANGELIST,
        {"action": "revoke", "_selected_action": [mine.pk, bobs_token.pk]},
    )
    assert list(OperatorToken.objects.all()) == [bobs_token]
    alice_ui.post(f"{CHANGELIST}{bobs_token.pk}/delete/", {"post": "yes"})
    assert OperatorToken.objects.filter(pk=bobs_token.pk).exists()


def test_an_operator_cannot_issue_a_token_for_someone_else(
    alice_ui: Client, operator_user: User, readonly_user: User
) -> None:
    alice_ui.post(CHANGELIST + "add/", {"name": "x", "expires_days": "1", "user": readonly_user.pk})
    assert OperatorToken.objects.get().user == operator_user


def test_a_superuser_sees_revokes_and_issues_for_everyone(
    admin_user: User, operator_user: User, readonly_user: User, bobs_token: OperatorToken
) -> None:
    client = Client()
    client.force_login(admin_user)
    assert "bob&#x27;s phone" in client.get(CHANGELIST).content.decode()
    client.post(
        CHANGELIST + "add/", {"name": "alice's", "expires_days": "1", "user": operator_user.pk}
    )
    assert OperatorToken.objects.filter(user=operator_user, name="alice's").exists()
    client.post(CHANGELIST, {"action": "revoke", "_selected_action": [bobs_token.pk]})
    assert not OperatorToken.objects.filter(pk=bobs_token.pk).exists()


def test_a_user_who_is_not_staff_has_no_token_admin(client: Client, db: None) -> None:
    user = User.objects.create_user("carol", password="pw-carol")
    client.force_login(user)
    assert client.get(CHANGELIST).status_code == 302  # to the admin login
