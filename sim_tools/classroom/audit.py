"""The teacher's admin actions, one line each, in the course folder's ``audit.log``.

JupyterHub logs every request; this keeps, apart and for good, the ones by which an admin changes
something: any request other than GET/HEAD (the REST API and the admin page: add, delete, stop,
start a user's server, change a password) and NativeAuthenticator's approve/discard links (GETs).
It wraps JupyterHub's own request logger (tornado's ``log_function``), so nothing else changes.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from jupyterhub.log import log_request

STATE_CHANGING_GETS = re.compile(r"/hub/(authorize|discard|confirm)/[^/?]+")
_lock = threading.Lock()


def is_admin_action(method: str, path: str, admin: bool) -> bool:
    """Whether a request by a user (``admin`` or not) is one the audit log keeps."""
    if not admin:
        return False
    return method not in ("GET", "HEAD", "OPTIONS") or bool(STATE_CHANGING_GETS.search(path))


def audited(path: str | Path) -> Callable[[Any], None]:
    """A tornado ``log_function``: JupyterHub's, plus a line in ``path`` for each admin action."""

    def log_function(handler: Any) -> None:
        log_request(handler)
        try:
            user = handler.current_user
        except Exception:
            return
        admin = bool(getattr(user, "admin", False))
        request = handler.request
        if not is_admin_action(request.method, request.path, admin):
            return
        when = datetime.now(UTC).isoformat(timespec="seconds")
        status, ip = handler.get_status(), request.remote_ip
        line = f"{when} {user.name} {request.method} {request.path} -> {status} from {ip}\n"
        with _lock, open(path, "a") as log:
            log.write(line)

    return log_function
