"""ROS domain ids for the students' servers: no two running servers share one.

The allocation lives in a JSON file in the course folder (``domains.json``: domain id → user and
the pid of their server), locked with ``flock`` while it is read and written, so it survives a hub
restart and two hubs on one folder cannot hand out the same id. A domain whose holder's process is
gone (the hub was killed before it could free it) is free again.

A domain id separates *well-behaved* programs only: any local process may set ``ROS_DOMAIN_ID`` to
another student's id and join that domain (docs/classroom.md says what does separate students).
"""

from __future__ import annotations

import fcntl
import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from sim_runtime.errors import InputError
from sim_runtime.processes import pid_alive

ROS_DOMAIN_MAX = 232  # rmw's limit with the default port mapping (7400 + 250 * id + ... < 65536)


class NoDomainLeft(RuntimeError):
    """Every domain of the pool is held by a running server: this one cannot start."""


def parse_range(text: str) -> range:
    """``"1-101"`` → range(1, 102); a single id ``"7"`` → range(7, 8)."""
    first, _, last = text.partition("-")
    try:
        low, high = int(first), int(last or first)
    except ValueError:
        raise InputError(f"domains {text!r}: expected FIRST-LAST, e.g. 1-101") from None
    if not 0 <= low <= high <= ROS_DOMAIN_MAX:
        raise InputError(f"domains {text!r}: ids must satisfy 0 <= FIRST <= LAST <= {ROS_DOMAIN_MAX}")
    return range(low, high + 1)


def _alive(pid: int | None) -> bool:
    return not pid or pid_alive(pid)  # no pid: allocated, its server not started yet: held


@dataclass(frozen=True)
class DomainPool:
    """The domain ids ``ids`` handed out through the state file ``path``."""

    path: Path
    ids: range

    @contextmanager
    def _locked(self) -> Iterator[dict[str, dict]]:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path.with_suffix(".lock"), "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                state = json.loads(self.path.read_text()) if self.path.exists() else {}
            except (OSError, json.JSONDecodeError):
                state = {}  # a damaged file: start over rather than refuse every student
            yield state
            tmp = self.path.with_suffix(".tmp")
            tmp.write_text(json.dumps(state, indent=1, sort_keys=True))
            os.replace(tmp, self.path)

    def allocate(self, user: str, pid: int | None = None) -> int:
        """The domain of ``user``: the one they hold, else the lowest free one.

        Raises :class:`NoDomainLeft` (with what to do) when every id is held by a running server."""
        with self._locked() as state:
            for domain, holder in list(state.items()):
                if not _alive(holder.get("pid")) or int(domain) not in self.ids:
                    del state[domain]
            for domain, holder in state.items():
                if holder["user"] == user:
                    return int(domain)
            free = [d for d in self.ids if str(d) not in state]
            if not free:
                raise NoDomainLeft(
                    f"all {len(self.ids)} ROS domains of this course server ({self.ids.start}-{self.ids.stop - 1}) "
                    f"are in use by running servers: try again when a classmate stops theirs, or ask the teacher "
                    f"to allow more (classroom init --domains) or to stop idle servers"
                )
            state[str(free[0])] = {"user": user, "pid": pid}
            return free[0]

    def set_pid(self, user: str, pid: int) -> None:
        """Record the pid of ``user``'s server (a dead pid frees the domain)."""
        with self._locked() as state:
            for holder in state.values():
                if holder["user"] == user:
                    holder["pid"] = pid

    def release(self, user: str) -> None:
        """Free ``user``'s domain (their server stopped)."""
        with self._locked() as state:
            for domain in [d for d, holder in state.items() if holder["user"] == user]:
                del state[domain]

    def holders(self) -> dict[int, str]:
        """Domain id → user, as held now."""
        with self._locked() as state:
            return {int(d): holder["user"] for d, holder in state.items()}
