"""Small facts about processes that more than one tool asks."""

from __future__ import annotations

import os


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` exists (a zombie counts: its parent has not reaped it yet).

    Another user's process exists too: signal 0 to it is refused with ``PermissionError``, which
    says it is there.
    """
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
