"""Who may call the Desk: its users (`--desk-user NAME:PASSWORD`) and how a call shows it.

The system 5+ API sends HTTP Basic credentials on every call. The older Desk logs in once
(`/admin/api/login`, the password sent as the Desk's browser encodes it: the SHA-256 of
"password#user@franka", its bytes written as comma-separated decimals, in base64) and then
sends the session it got back as the `authorization` cookie (or header, on the Pilot's
event socket). Either is accepted on either dialect, as the clients mix them.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import hmac
import secrets
from dataclasses import dataclass, field

DEFAULT_USER = ("franka", "franka")  # documented in docs/desk.md


def parse_user(text: str) -> tuple[str, str]:
    """NAME:PASSWORD (ValueError saying what is wrong)."""
    name, sep, password = text.partition(":")
    if not sep or not name or not password:
        raise ValueError(f"{text!r}: expected NAME:PASSWORD")
    return name, password


def browser_password(user: str, password: str) -> str:
    """The password as the older Desk's login form sends it."""
    digest = hashlib.sha256(f"{password}#{user}@franka".encode()).digest()
    return base64.b64encode(",".join(str(b) for b in digest).encode()).decode()


def _same(a: str, b: str) -> bool:
    return hmac.compare_digest(a.encode(), b.encode())


@dataclass
class Users:
    accounts: dict[str, str] = field(default_factory=lambda: dict([DEFAULT_USER]))
    sessions: dict[str, str] = field(default_factory=dict)  # login session -> user

    def login(self, user, password) -> str | None:
        """A session for the older Desk's login, or None (wrong user or password)."""
        if not isinstance(user, str) or not isinstance(password, str):
            return None
        expected = self.accounts.get(user)
        if expected is None:
            return None
        # The encoded form may arrive with base64's line breaks (encodebytes) or without.
        given = "".join(password.split())
        if not _same(given, browser_password(user, expected)):
            return None
        session = secrets.token_urlsafe(24)
        self.sessions[session] = user
        return session

    def basic(self, header: str) -> str | None:
        """The user an `Authorization: Basic ...` header names, if its password is right."""
        scheme, _, value = header.partition(" ")
        if scheme.lower() != "basic":
            return None
        try:
            user, sep, password = base64.b64decode(value.strip(), validate=True).decode(
                "utf-8").partition(":")
        except (binascii.Error, UnicodeDecodeError):
            return None
        expected = self.accounts.get(user)
        if not sep or expected is None or not _same(password, expected):
            return None
        return user

    def logout(self, user: str | None) -> None:
        """The older Desk's logout: that user's sessions end."""
        for session in [s for s, who in self.sessions.items() if who == user]:
            del self.sessions[session]

    def session(self, value: str | None) -> str | None:
        if not value:
            return None
        for session, user in self.sessions.items():
            if _same(value, session):
                return user
        return None

    def caller(self, authorization: str | None, cookie_session: str | None) -> str | None:
        """Who calls: Basic credentials, a login session as cookie or as the bare
        `authorization` header; None when nothing valid was shown."""
        if authorization:
            user = self.basic(authorization)
            if user is None:
                user = self.session(authorization.strip())
            if user is not None:
                return user
        return self.session(cookie_session)
