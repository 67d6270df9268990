"""The course's spawner: JupyterHub's LocalProcessSpawner, one real Unix user per student.

On top of LocalProcessSpawner (which runs each server as its user, in their home):
- the student's account is made on their first start (:mod:`.users`; home 0700, the course group);
- each running server holds its own ROS domain (:mod:`.domains`), in its environment as
  ``ROS_DOMAIN_ID``; none left → the start is refused with what to do;
- the limits of :mod:`.limits` (memory, processes, nice) are set before the server becomes the student;
- however the server ends (stopped from the hub, culled, crashed, killed), every process of the
  student is killed afterwards (the worlds run in their own session; nothing else would end them)
  and the domain is freed.
"""

from __future__ import annotations

import asyncio
import pwd
from collections.abc import Callable
from pathlib import Path
from typing import Any

from jupyterhub.spawner import LocalProcessSpawner, set_user_setuid
from traitlets import Integer, Unicode

from sim_tools.classroom.domains import DomainPool, parse_range
from sim_tools.classroom.limits import Limits, join_cgroup, memory_cgroup, parse_bytes, remove_cgroup
from sim_tools.classroom.users import ensure_student, kill_everything_of


class ClassroomSpawner(LocalProcessSpawner):
    """A student's server: their own Unix user, ROS domain and limits (docs/classroom.md)."""

    domains = Unicode("1-101", config=True, help="ROS domain ids handed to running servers (FIRST-LAST)")
    domain_state = Unicode("domains.json", config=True, help="the allocation's state file (relative: to the hub's cwd)")
    student_group = Unicode("robot_sims_students", config=True, help="Unix group of the students' accounts")
    home_root = Unicode("/home", config=True, help="where new students' homes are made")
    memory_limit = Unicode("4G", config=True, help="RLIMIT_AS per process, a cgroup total if possible ('' = none)")
    max_processes = Integer(512, config=True, help="RLIMIT_NPROC: processes + threads of the user (0 = none)")
    nice = Integer(5, config=True, help="nice level of the student's server and its children")

    ros_domain = Integer(-1)

    @property
    def pool(self) -> DomainPool:
        return DomainPool(Path(self.domain_state).absolute(), parse_range(self.domains))

    @property
    def limits(self) -> Limits:
        return Limits(parse_bytes(self.memory_limit) if self.memory_limit else 0, self.max_processes, self.nice)

    async def start(self) -> Any:
        await asyncio.to_thread(ensure_student, self.user.name, self.student_group, Path(self.home_root))
        self.ros_domain = self.pool.allocate(self.user.name)
        self.log.info("ROS domain %d for %s", self.ros_domain, self.user.name)
        self._cgroup = memory_cgroup(self.user.name, self.limits.memory) if self.limits.memory else None
        try:
            address = await super().start()
        except BaseException:
            self.pool.release(self.user.name)
            raise
        self.pool.set_pid(self.user.name, self.pid)
        return address

    def get_env(self) -> dict[str, str]:
        env = super().get_env()
        if self.ros_domain >= 0:
            env["ROS_DOMAIN_ID"] = str(self.ros_domain)
        return env

    def make_preexec_fn(self, name: str) -> Callable[[], None]:
        become_student = set_user_setuid(name)
        limits, group = self.limits, getattr(self, "_cgroup", None)

        def preexec() -> None:  # in the forked child, still root
            if group is not None:
                join_cgroup(group)
            limits.apply()
            become_student()

        return preexec

    async def run_post_stop_hook(self) -> Any:
        """However the server ended: no process of the student is left, and the domain is free."""
        try:
            account = pwd.getpwnam(self.user.name)
        except KeyError:
            account = None
        if account is not None and account.pw_uid != 0:
            left = await asyncio.to_thread(kill_everything_of, account.pw_uid, account.pw_gid)
            if left:
                self.log.warning("processes of %s outlived their server: %s", self.user.name, left)
            remove_cgroup(self.user.name)
        self.pool.release(self.user.name)
        self.ros_domain = -1
        return super().run_post_stop_hook()

    def get_state(self) -> dict[str, Any]:
        state = super().get_state()
        if self.ros_domain >= 0:
            state["ros_domain"] = self.ros_domain
        return state

    def load_state(self, state: dict[str, Any]) -> None:
        super().load_state(state)
        self.ros_domain = int(state.get("ros_domain", -1))

    def clear_state(self) -> None:
        super().clear_state()
        self.ros_domain = -1
