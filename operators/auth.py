"""Operator token authentication: django-rest-knox, with one indexed query per request."""

from __future__ import annotations

from typing import Any

from drf_spectacular.extensions import OpenApiAuthenticationExtension
from knox.auth import TokenAuthentication
from rest_framework.exceptions import AuthenticationFailed

from operators.models import OperatorToken


class OperatorTokenAuthentication(TokenAuthentication):
    """`Authorization: Token <token>` → (User, OperatorToken).

    knox looks a token up with one query: `token_key` (the token's first 15 characters, an
    indexed column) joined to its user, then compares SHA-512 digests in constant time.
    Its `_cleanup_token` would add a second query on every request (all the user's other
    tokens, to delete the expired ones); here an expired token is simply refused, and stays
    listed as expired in the admin until its owner revokes it.
    """

    def authenticate_credentials(self, token: bytes) -> tuple[Any, OperatorToken]:
        try:
            token.decode("utf-8")
        except UnicodeDecodeError:  # knox would let this through as a 500
            raise AuthenticationFailed("Invalid token.") from None
        return super().authenticate_credentials(token)

    def _cleanup_token(self, auth_token: OperatorToken) -> bool:
        return auth_token.is_expired()


class OperatorTokenScheme(OpenApiAuthenticationExtension):
    """Describes the operator token in the OpenAPI schema (knox's own extension matches only
    knox's class, not subclasses)."""

    target_class = OperatorTokenAuthentication
    name = "operatorToken"

    def get_security_definition(self, auto_schema: Any) -> dict[str, str]:
        return {
            "type": "apiKey",
            "in": "header",
            "name": "Authorization",
            "description": "An operator's personal API token: `Token <token>`.",
        }
