"""Per-student limits, applied to a student's server as it starts (before it becomes the student).

What each does, and does not, guarantee (docs/classroom.md repeats it for teachers):

- ``memory`` → ``RLIMIT_AS``: each *process* of the student may map at most this much virtual
  memory (an allocation beyond fails with MemoryError / ENOMEM). It is per process, not a total per
  student: a student with several worlds may use several times it. Where a memory cgroup can be
  written (cgroup v2 ``memory.max`` or v1 ``memory.limit_in_bytes``), the student's server and all
  it starts are also put in one cgroup capped at ``memory``: a real total (the kernel's OOM killer
  ends the student's largest process, never another student's).
- ``processes`` → ``RLIMIT_NPROC``: the student's Unix user may own at most this many processes
  *and threads* in total (a fork bomb stops there). Counted over all the user's processes on the
  machine; the DDS middleware and numba start threads, so keep it well above a few hundred.
- ``nice`` → the server and everything it starts run at this nice level: under contention the
  hub, the proxy and the teacher's own processes get the CPU first. Among students sharing the
  same nice level it does not divide the CPU fairly (a student with more threads gets more).
"""

from __future__ import annotations

import contextlib
import os
import resource
from dataclasses import dataclass
from pathlib import Path

from sim_runtime.errors import InputError

UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
CGROUP_ROOT = Path("/sys/fs/cgroup")
CGROUP_NAME = "robot_sims_classroom"


def parse_bytes(text: str) -> int:
    """``"4G"`` → 4 GiB (K, M, G, T are powers of 1024; a plain number is bytes)."""
    value = text.strip().upper().removesuffix("B").removesuffix("I")
    number, unit = (value[:-1], value[-1]) if value[-1:] in UNITS and value[-1:] else (value, "")
    try:
        result = int(float(number) * UNITS[unit])
    except ValueError:
        raise InputError(f"memory {text!r}: expected a size such as 4G or 512M") from None
    if result <= 0:
        raise InputError(f"memory {text!r}: must be > 0")
    return result


@dataclass(frozen=True)
class Limits:
    """What one student's server may use (0 = no limit of that kind)."""

    memory: int = 0
    processes: int = 0
    nice: int = 0

    def apply(self) -> None:
        """Set the limits on this process (in the spawner's preexec, still root, before setuid)."""
        if self.memory:
            resource.setrlimit(resource.RLIMIT_AS, (self.memory, self.memory))
        if self.processes:
            resource.setrlimit(resource.RLIMIT_NPROC, (self.processes, self.processes))
        if self.nice:
            os.nice(self.nice)


def memory_cgroup(user: str, memory: int) -> Path | None:
    """A memory cgroup for ``user`` capped at ``memory`` bytes, or None where none can be made
    (no writable cgroup filesystem, e.g. an unprivileged container): RLIMIT_AS is then the only cap."""
    for root, limit_file in ((CGROUP_ROOT, "memory.max"), (CGROUP_ROOT / "memory", "memory.limit_in_bytes")):
        if not (root / "cgroup.procs").exists() or (root is CGROUP_ROOT and not (root / "cgroup.controllers").exists()):
            continue
        if root is CGROUP_ROOT and "memory" not in (root / "cgroup.controllers").read_text().split():
            continue
        group = root / CGROUP_NAME / user
        try:
            group.mkdir(parents=True, exist_ok=True)
            if root is CGROUP_ROOT:  # v2: the parent must hand the memory controller down
                subtree = root / CGROUP_NAME / "cgroup.subtree_control"
                if "memory" not in subtree.read_text().split():
                    subtree.write_text("+memory")
            (group / limit_file).write_text(str(memory))
        except OSError:
            continue
        return group
    return None


def join_cgroup(group: Path) -> None:
    """Move this process into ``group`` (the spawner's preexec: children follow)."""
    (group / "cgroup.procs").write_text(str(os.getpid()))


def remove_cgroup(user: str) -> None:
    """Remove ``user``'s memory cgroup, if any (once their processes are gone)."""
    for root in (CGROUP_ROOT, CGROUP_ROOT / "memory"):
        with contextlib.suppress(OSError):  # none there, or a process still in it (the next start reuses it)
            (root / CGROUP_NAME / user).rmdir()


def cgroup_of(user: str) -> Path | None:
    """The memory cgroup folder of ``user`` if the spawner made one."""
    for root in (CGROUP_ROOT, CGROUP_ROOT / "memory"):
        if (root / CGROUP_NAME / user).is_dir():
            return root / CGROUP_NAME / user
    return None
