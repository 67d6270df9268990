"""The course server for real: `classroom init` + `classroom serve` start JupyterHub, its proxy and
LocalProcessSpawner servers running as real Unix users (as root, as a teacher's server runs).

Three students sign up and sign in in headless Chromium (one browser each, open side by side), the
teacher approves them, each student's server gets its own ROS domain, each opens the studio from
their JupyterLab and drives a Create world with the keys; over ROS each world is seen in its
student's domain only; a classmate's URL is refused (in the browser too), homes are private, and
stopping a server leaves no process of the student. The test users are `rstest_*` accounts,
removed afterwards.
"""

from __future__ import annotations

import json
import math
import os
import pwd
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from studio_browser_support import NO_CHROMIUM

pytest.importorskip("jupyterhub", reason="the classroom extra: pip install 'robot_sims[classroom]'")
requests = pytest.importorskip("requests")

if os.geteuid() != 0 or shutil.which("useradd") is None:
    pytest.skip("the course server makes Unix users: run as root", allow_module_level=True)
if NO_CHROMIUM:
    pytest.skip(NO_CHROMIUM, allow_module_level=True)

from classroom_hub_support import (  # noqa: E402 (after the skips: Chromium and root are known there)
    SPAWN_SECONDS,
    STUDIO_SECONDS,
    WORLD_SECONDS,
    Hub,
    StudentListener,
    body_text,
    commands_of,
    environment,
    in_lab,
    is_refusal,
    open_studio_from_lab,
    press,
    remove_users,
    robot_selected,
    server_process,
    session_of,
    sign_in_in_browser,
    sign_up_in_browser,
    start_world,
    student_python,
    studio_page_shown,
)
from studio_browser_support import free_port, new_browser, wait  # noqa: E402

from sim_tools.classroom.domains import DomainPool, NoDomainLeft, parse_range  # noqa: E402
from sim_tools.classroom.limits import cgroup_of, parse_bytes  # noqa: E402
from sim_tools.classroom.users import NotAStudent, ensure_student, processes_of  # noqa: E402
from sim_tools.cli import executable_command  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
GROUP = "rstest_students"
ADMIN, ALICE, BOB, CAROL, DAVE = "rstest_teacher", "rstest_alice", "rstest_bob", "rstest_carol", "rstest_dave"
STUDENTS = (ALICE, BOB, CAROL, DAVE)
IN_CHROMIUM = (ALICE, BOB, CAROL)  # the class working side by side; Dave (HTTP) is the one refused a domain
WORLD_NS = {ALICE: "/alice_create", BOB: "/bob_create", CAROL: "/carol_create"}  # one name each: who sees whom
DOMAINS = "202-204"  # this module's domains (of 202-216, which no other test hands out): 3 for 4 students
HUB_START_SECONDS = 180.0
DRIVEN_M = 0.3  # how far each robot is driven by the keys (0.2 m/s: 1.5 s of sim time)

# The first test waits for the hub, three servers, three studios and their worlds: 80 s here at a
# load of 10-14 on 2 cores; the ceilings above allow for far slower.
pytestmark = pytest.mark.timeout(1200)


@pytest.fixture(scope="module")
def hub() -> Iterator[Hub]:
    remove_users((ADMIN, *STUDENTS), GROUP)  # a previous run killed before its teardown
    course = Path(tempfile.mkdtemp(prefix="rstest_course_"))
    port = free_port()
    python = student_python()
    init = subprocess.run(
        executable_command(
            "classroom",
            [
                "init", str(course), "--admin", ADMIN, "--bind-url", f"http://127.0.0.1:{port}/",
                "--hub-port", str(free_port()), "--proxy-api-port", str(free_port()),
                "--python", python, "--domains", DOMAINS, "--group", GROUP,
            ],
        ),
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert init.returncode == 0, init.stdout + init.stderr
    log = course / "hub.log"
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    with open(log, "w") as out:
        server = subprocess.Popen(
            executable_command("classroom", ["serve", str(course)]), stdout=out, stderr=subprocess.STDOUT, env=env
        )
    running = Hub(f"http://127.0.0.1:{port}", course, log, server.pid)
    try:
        deadline = time.monotonic() + HUB_START_SECONDS
        while time.monotonic() < deadline and server.poll() is None:
            try:
                if requests.get(f"{running.url}/hub/health", timeout=5).status_code == 200:
                    break
            except requests.ConnectionError:
                pass
            time.sleep(0.5)
        else:
            pytest.fail(f"no hub at {running.url} (exit {server.poll()})\n{running.tail()}")
        yield running
    finally:
        server.send_signal(signal.SIGINT)  # the hub stops every server it started
        try:
            server.wait(60)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        remove_users((ADMIN, *STUDENTS), GROUP)
        shutil.copy(log, Path(tempfile.gettempdir()) / "rstest_classroom_hub_last.log")  # for a failure's reader
        shutil.rmtree(course, ignore_errors=True)
        if python != sys.executable:  # the students' venv made for this run
            shutil.rmtree(Path(python).parent.parent, ignore_errors=True)


@pytest.fixture(scope="module")
def browsers(hub: Hub) -> Iterator[dict[str, Any]]:
    """A headless Chromium per student of the class, all open at once (after the hub: closed before it)."""
    with ExitStack() as stack:
        yield {name: stack.enter_context(new_browser("1400,1000")) for name in IN_CHROMIUM}


@pytest.fixture(scope="module")
def classroom(hub: Hub, browsers: dict[str, Any]) -> dict[str, requests.Session]:
    """The teacher and four approved students, signed in: Alice, Bob and Carol in their browsers
    (which start their servers, as signing in does), the teacher and Dave over HTTP. Each name's
    ``requests`` session holds its browser's cookies."""
    hub.sign_up(ADMIN)
    for name, driver in browsers.items():
        sign_up_in_browser(driver, hub, name)
    hub.sign_up(DAVE)
    sign_in_in_browser(browsers[ALICE], hub, ALICE)
    not_yet = "has not been authorized by an administrator yet"
    wait(browsers[ALICE], lambda d: not_yet in body_text(d), timeout=60.0)
    teacher = hub.sign_in(ADMIN)
    for name in STUDENTS:  # the approve buttons of /hub/authorize
        page = teacher.get(f"{hub.url}/hub/authorize", timeout=60)
        assert f"authorize/{name}" in page.text, hub.what(page)
        assert teacher.get(f"{hub.url}/hub/authorize/{name}", timeout=60).status_code == 200
    for name, driver in browsers.items():  # all three at once: each waits on the hub's spawn page
        sign_in_in_browser(driver, hub, name)
    for name, driver in browsers.items():
        wait(driver, lambda d, n=name: in_lab(d, hub, n), timeout=SPAWN_SECONDS)
    return {ADMIN: teacher, DAVE: hub.sign_in(DAVE), **{name: session_of(d) for name, d in browsers.items()}}


@pytest.fixture(scope="module")
def running(hub: Hub, classroom: dict[str, requests.Session]) -> dict[str, int]:
    """Alice's and Bob's servers (up for the whole module, whatever the order): name → server pid."""
    for name in (ALICE, BOB):
        hub.wait_ready(classroom[name], name)
    return {name: server_process(name) for name in (ALICE, BOB)}


@dataclass
class Seen:
    """What a listener in one student's domain saw of the class's worlds."""

    domain: int
    driven_m: float  # how far their robot moved from its pose before its keys were pressed
    topics: set[str]  # every topic in the domain


@pytest.fixture(scope="module")
def driven(hub: Hub, browsers: dict[str, Any], classroom: dict[str, requests.Session]) -> dict[str, Seen]:
    """Alice, Bob and Carol each open the studio from their JupyterLab, start a world from the page
    and drive it forward with the arrow keys — at the same time, in their own browsers — while a
    listener of each one's, in their domain (their server's ``ROS_DOMAIN_ID``), watches."""
    from selenium.webdriver.common.keys import Keys

    from create_sim.spec import OVERHEAD_POSE_TOPIC

    for name in IN_CHROMIUM:
        hub.wait_ready(classroom[name], name)
    for name, driver in browsers.items():
        open_studio_from_lab(driver, hub, name)
    for driver in browsers.values():
        wait(driver, studio_page_shown, timeout=STUDIO_SECONDS)
    listeners: dict[str, StudentListener] = {}
    try:
        for name in IN_CHROMIUM:
            listeners[name] = StudentListener(name, GROUP, f"{WORLD_NS[name]}/{OVERHEAD_POSE_TOPIC}")
        for name, driver in browsers.items():
            start_world(driver, WORLD_NS[name])
        first = {}
        for name, driver in browsers.items():
            wait(driver, lambda d, n=name: robot_selected(d, WORLD_NS[n]), timeout=WORLD_SECONDS)
            heard = listeners[name].until(lambda n=name: bool(listeners[n].poses), timeout=60.0)
            assert heard, f"{name}'s listener heard no pose\n{listeners[name].said()}"
            first[name] = listeners[name].poses[-1]  # standing still: no key pressed yet
        for driver in browsers.values():
            press(driver, Keys.ARROW_UP, Keys.ARROW_UP)  # 0.2 m/s forward
        seen = {}
        for name, driver in browsers.items():
            listener = listeners[name]
            listener.until(lambda n=name: math.dist(listeners[n].poses[-1], first[n]) > DRIVEN_M, timeout=60.0)
            press(driver, " ")  # stop
            own = f"{WORLD_NS[name]}/{OVERHEAD_POSE_TOPIC}"
            listener.until(lambda n=name, t=own: t in listeners[n].topics, timeout=30.0)
            seen[name] = Seen(listener.domain, math.dist(listener.poses[-1], first[name]), set(listener.topics))
    finally:
        for listener in listeners.values():
            listener.close()
    return seen


def test_three_students_drive_their_own_worlds_side_by_side_in_chromium(driven):
    assert len({seen.domain for seen in driven.values()}) == 3, driven
    for name, seen in driven.items():
        assert seen.driven_m > DRIVEN_M, (name, seen)


def test_over_ros_each_student_sees_their_own_world_and_no_classmates(driven):
    for name, seen in driven.items():
        poses = {topic for topic in seen.topics if topic.endswith("/overhead_pose")}
        assert poses == {f"{WORLD_NS[name]}/overhead_pose"}, (name, seen)
        theirs = [ns for other, ns in WORLD_NS.items() if other != name]
        assert not [topic for topic in seen.topics if topic.startswith(tuple(theirs))], (name, seen)


def test_a_students_chromium_is_refused_a_classmates_studio(hub, browsers, classroom):
    driver = browsers[ALICE]
    own = driver.current_window_handle
    driver.switch_to.new_window("tab")
    try:
        driver.get(f"{hub.url}/user/{BOB}/robot_sims/")
        wait(driver, lambda d: is_refusal(d, hub), timeout=60.0)
        assert not studio_page_shown(driver), body_text(driver)
    finally:
        driver.close()
        driver.switch_to.window(own)


def test_each_students_server_runs_as_them_in_a_domain_of_its_own(hub, running):
    domains = {}
    for name, pid in running.items():
        assert Path(f"/proc/{pid}").stat().st_uid == pwd.getpwnam(name).pw_uid
        env = environment(pid)
        domains[name] = int(env["ROS_DOMAIN_ID"])
        assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
        assert Path(env["FASTRTPS_DEFAULT_PROFILES_FILE"]).is_file()
        assert env["ROBOT_SIMS_MAX_WORLDS"] == "2"
        limits = Path(f"/proc/{pid}/limits").read_text()
        assert re.search(rf"Max address space\s+{4 << 30}\s+{4 << 30}", limits), limits
        assert re.search(r"Max processes\s+512\s+512", limits), limits
        assert int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[16]) == 5  # nice
        group = cgroup_of(name)  # made where the hub may write a memory cgroup (here: yes)
        if group is not None:
            assert str(pid) in (group / "cgroup.procs").read_text().split()
            limit = group / ("memory.max" if (group / "memory.max").exists() else "memory.limit_in_bytes")
            assert int(limit.read_text()) == parse_bytes("4G")
    assert len(set(domains.values())) == 2 and set(domains.values()) <= set(parse_range(DOMAINS)), domains
    held = json.loads((hub.course / "domains.json").read_text())
    assert {holder["user"]: int(domain) for domain, holder in held.items() if holder["user"] in domains} == domains


def test_a_student_reaches_their_own_server_and_not_a_classmates(hub, classroom, running):
    mine = classroom[ALICE].get(f"{hub.url}/user/{ALICE}/lab", timeout=60)  # through the hub's OAuth
    assert mine.status_code == 200 and mine.url.startswith(f"{hub.url}/user/{ALICE}/lab"), hub.what(mine)
    theirs = classroom[ALICE].get(f"{hub.url}/user/{BOB}/lab", timeout=60)
    assert theirs.status_code == 403, hub.what(theirs)
    api = classroom[ALICE].get(f"{hub.url}/user/{BOB}/api/contents", timeout=60)
    assert api.status_code == 403 and ".bashrc" not in api.text, hub.what(api)
    anonymous = requests.get(f"{hub.url}/user/{BOB}/lab", timeout=60)
    assert anonymous.url.startswith(f"{hub.url}/hub/login"), hub.what(anonymous)


def test_a_student_opens_their_studio_and_not_a_classmates(hub, classroom, running):
    studio = classroom[ALICE].get(f"{hub.url}/user/{ALICE}/robot_sims/", timeout=300)  # started on first use
    assert studio.status_code == 200 and "nicegui" in studio.text.lower(), hub.what(studio)
    theirs = classroom[ALICE].get(f"{hub.url}/user/{BOB}/robot_sims/", timeout=60)
    assert theirs.status_code == 403, hub.what(theirs)


def listening_addresses(uid: int) -> set[str]:
    """The local addresses of every TCP socket that a process of ``uid`` listens on."""
    inodes = set()
    for pid in processes_of(uid):
        try:
            links = [os.readlink(fd) for fd in Path(f"/proc/{pid}/fd").iterdir()]
        except OSError:
            continue
        inodes |= {link[8:-1] for link in links if link.startswith("socket:[")}
    addresses = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in inodes:  # 0A: LISTEN
                addresses.add(fields[1].rsplit(":", 1)[0])
    return addresses


def test_a_students_processes_listen_on_the_loopback_only(running):
    loopback = {"0100007F", "00000000000000000000000001000000"}  # 127.0.0.1, ::1 as /proc/net spells them
    addresses = listening_addresses(pwd.getpwnam(ALICE).pw_uid)
    assert addresses and addresses <= loopback, addresses


def test_homes_are_private_and_a_student_cannot_list_a_classmates(running):
    for name in (ALICE, BOB):
        assert Path(pwd.getpwnam(name).pw_dir).stat().st_mode & 0o777 == 0o700
    bob_home = pwd.getpwnam(BOB).pw_dir
    listing = subprocess.run(["setpriv", "--reuid", ALICE, "--regid", GROUP, "--init-groups", "ls", bob_home],
                             capture_output=True, text=True)  # fmt: skip
    assert listing.returncode != 0 and "Permission denied" in listing.stderr


def test_the_idle_culler_runs_as_a_hub_service(hub, classroom):
    service = hub.api(classroom[ADMIN], "GET", "services/idle-culler")
    assert service.status_code == 200, hub.what(service)
    assert "--timeout=3600" in service.json()["command"]
    culler = subprocess.run(["pgrep", "-f", "-P", str(hub.pid), "jupyterhub_idle_culler"], capture_output=True)
    assert culler.returncode == 0, hub.tail()


def test_the_teachers_approvals_are_in_the_audit_log(hub, classroom):
    lines = (hub.course / "audit.log").read_text().splitlines()
    for name in STUDENTS:
        assert any(f" {ADMIN} GET /hub/authorize/{name} -> " in line for line in lines), lines


def test_stopping_a_server_leaves_no_process_of_the_student(hub, classroom, running, driven):
    """Carol's server, her studio and the world she drove (the others' stay up for the other tests,
    in any order)."""
    hub.wait_ready(classroom[CAROL], CAROL)
    assert any("create_world" in command for command in commands_of(CAROL)), commands_of(CAROL)
    # Three servers hold the three domains: a fourth student is refused, told why.
    refused = hub.api(classroom[DAVE], "POST", f"users/{DAVE}/server")
    said = refused.text + hub.api(classroom[DAVE], "GET", f"users/{DAVE}/server/progress").text
    assert "all 3 ROS domains of this course server (202-204) are in use" in said, hub.what(refused)
    assert not hub.api(classroom[DAVE], "GET", f"users/{DAVE}").json().get("servers"), hub.tail()
    uid = pwd.getpwnam(CAROL).pw_uid
    # A process of Carol's outside her server's tree (as a world is: its own session).
    stray = subprocess.Popen(["setpriv", "--reuid", CAROL, "--regid", GROUP, "--init-groups", "setsid", "sleep", "600"])
    deadline = time.monotonic() + 30  # setpriv becomes Carol only once it has started
    while stray.pid not in processes_of(uid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert stray.pid in processes_of(uid) and len(processes_of(uid)) >= 2
    done = hub.api(classroom[CAROL], "DELETE", f"users/{CAROL}/server")
    assert done.status_code in (202, 204), hub.what(done)
    hub.wait_stopped(classroom[CAROL], CAROL)
    deadline = time.monotonic() + 30
    while processes_of(uid) and time.monotonic() < deadline:
        time.sleep(0.2)
    ps = subprocess.run(["ps", "-u", CAROL, "-o", "pid=,stat=,args="], capture_output=True, text=True).stdout
    assert [line for line in ps.splitlines() if " Z" not in line] == [], ps
    stray.wait(10)
    assert cgroup_of(CAROL) is None  # her memory cgroup is removed with her processes
    held = {holder["user"] for holder in json.loads((hub.course / "domains.json").read_text()).values()}
    assert CAROL not in held and {ALICE, BOB} <= held  # her domain is free again, theirs are kept


def test_more_servers_than_domains_are_refused_with_what_to_do(tmp_path):
    pool = DomainPool(tmp_path / "domains.json", parse_range("202-203"))
    assert [pool.allocate("a", os.getpid()), pool.allocate("b", os.getpid())] == [202, 203]
    assert pool.allocate("a") == 202  # a student holds one domain, whatever they start
    with pytest.raises(NoDomainLeft, match=r"all 2 ROS domains .*202-203.* in use.*--domains"):
        pool.allocate("c")
    pool.release("a")
    assert pool.allocate("c") == 202


def test_a_domain_held_by_a_dead_server_is_free_again(tmp_path):
    dead = subprocess.Popen(["true"])
    dead.wait()
    pool = DomainPool(tmp_path / "domains.json", parse_range("202-202"))
    pool.allocate("a", dead.pid)
    assert pool.allocate("b") == 202


def test_an_existing_account_outside_the_course_cannot_become_a_student():
    import grp

    made_group = GROUP not in {group.gr_name for group in grp.getgrall()}
    try:
        with pytest.raises(NotAStudent, match="not a student of this course"):
            ensure_student("daemon", GROUP)
        with pytest.raises(NotAStudent, match="cannot be a Unix account"):
            ensure_student("../etc", GROUP)
    finally:
        if made_group:
            subprocess.run(["groupdel", GROUP], capture_output=True)
