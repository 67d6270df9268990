"""NativeAuthenticator (sign-up, teacher's approval, throttled sign-in) working on JupyterHub 6.

nativeauthenticator 1.3's login handler times each sign-in with ``self.statsd``, which JupyterHub 6
no longer has: every sign-in was a 500 error. Its handler here gets a timer that does nothing;
everything else is NativeAuthenticator's (its settings stay ``c.NativeAuthenticator.*``).
"""

from __future__ import annotations

from typing import Any

from nativeauthenticator import NativeAuthenticator
from nativeauthenticator.handlers import LoginHandler


class _NoTimer:
    def timer(self, _name: str) -> _NoTimer:
        return self

    def start(self) -> _NoTimer:
        return self

    def stop(self, send: bool = True) -> None:
        return None


class ClassroomLoginHandler(LoginHandler):
    @property
    def statsd(self) -> Any:
        return getattr(super(), "statsd", None) or _NoTimer()


class ClassroomAuthenticator(NativeAuthenticator):
    """NativeAuthenticator, its sign-in page fixed for JupyterHub 6."""

    def get_handlers(self, app: Any) -> list[tuple[str, Any]]:
        return [
            (path, ClassroomLoginHandler if handler is LoginHandler else handler)
            for path, handler in super().get_handlers(app)
        ]
