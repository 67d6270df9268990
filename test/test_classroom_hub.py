"""The course server for real: `classroom init` + `classroom serve` start JupyterHub, its proxy and
LocalProcessSpawner servers running as real Unix users (as root, as a teacher's server runs).

Students sign up through the hub's forms, the teacher approves them, each student's server gets
its own ROS domain, a classmate's URL is refused, homes are private, and stopping a server leaves
no process of the student. The test users are `rstest_*` accounts, removed afterwards.
"""

from __future__ import annotations

import json
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
from pathlib import Path

import pytest

from sim_tools.classroom.domains import DomainPool, NoDomainLeft, parse_range
from sim_tools.classroom.limits import cgroup_of, parse_bytes, remove_cgroup
from sim_tools.classroom.users import NotAStudent, ensure_student, processes_of
from sim_tools.cli import executable_command

pytest.importorskip("jupyterhub", reason="the classroom extra: pip install 'robot_sims[classroom]'")
requests = pytest.importorskip("requests")

ROOT = Path(__file__).resolve().parent.parent
GROUP = "rstest_students"
ADMIN, ALICE, BOB, CAROL, DAVE = "rstest_teacher", "rstest_alice", "rstest_bob", "rstest_carol", "rstest_dave"
STUDENTS = (ALICE, BOB, CAROL, DAVE)
PASSWORD = "a long classroom password 1"
DOMAINS = "202-204"  # this module's domains (of 202-216, which no other test hands out): 3 for 4 students
HUB_START_SECONDS = 180.0  # ceilings: a busy 2-core machine starts a hub and servers slowly
SPAWN_SECONDS = 240.0

pytestmark = pytest.mark.timeout(600)  # the first test waits for the hub and two servers (2 min here)

if os.geteuid() != 0 or shutil.which("useradd") is None:
    pytest.skip("the course server makes Unix users: run as root", allow_module_level=True)


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def student_python() -> str:
    """An interpreter students may run with this checkout's packages. The venv's own if others may
    enter it; here it lies under /root (0700), so — as docs/classroom.md tells teachers — students
    get a venv outside any home: the system's Python 3.11 over the same site-packages."""
    try:
        subprocess.run([sys.executable, "-c", "1"], preexec_fn=lambda: os.setuid(65534), check=True, cwd="/")
        return sys.executable
    except (OSError, subprocess.CalledProcessError):
        pass
    venv = Path(tempfile.mkdtemp(prefix="rstest_venv_"))
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    base = shutil.which(version, path="/usr/local/bin:/usr/bin") or pytest.fail(f"no {version} for the students")
    subprocess.run([base, "-m", "venv", "--without-pip", str(venv)], check=True)
    site = next((venv / "lib").glob("python3.*")) / "site-packages"
    ours = Path(sys.prefix) / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" / "site-packages"
    (site / "robot_sims_venv.pth").write_text(f"import site; site.addsitedir({str(ours)!r})\n")
    for libs in ours.glob("ros_*.libs"):  # the ROS wheels find their libraries beside the prefix
        (site / libs.name).symlink_to(libs)
    for lib in (Path(sys.prefix) / "lib").iterdir():
        if not lib.name.startswith("python"):
            (venv / "lib" / lib.name).symlink_to(lib)
    if not studio_entry_installed():  # an editable install older than the studio's entry point
        info = site / "robot_sims_studio_entry-0.dist-info"
        info.mkdir()
        (info / "METADATA").write_text("Metadata-Version: 2.1\nName: robot_sims_studio_entry\nVersion: 0\n")
        entry = "robot_sims = studio.jupyter:setup_studio"
        (info / "entry_points.txt").write_text(f"[jupyter_serverproxy_servers]\n{entry}\n")
    for folder in ("etc", "share"):  # Jupyter's extensions are enabled (etc/) and served (share/) from there
        (venv / folder).symlink_to(Path(sys.prefix) / folder)
    venv.chmod(0o755)
    return str(venv / "bin" / "python")


def studio_entry_installed() -> bool:
    from importlib.metadata import entry_points

    return any(entry.name == "robot_sims" for entry in entry_points(group="jupyter_serverproxy_servers"))


def remove_users() -> None:
    for name in (ADMIN, *STUDENTS):
        try:
            uid = pwd.getpwnam(name).pw_uid
        except KeyError:
            continue
        subprocess.run(["pkill", "-KILL", "-U", str(uid)], capture_output=True)  # by uid: only theirs
        subprocess.run(["userdel", "-r", name], capture_output=True)
        remove_cgroup(name)
    subprocess.run(["groupdel", GROUP], capture_output=True)


class Hub:
    def __init__(self, url: str, course: Path, log: Path, pid: int):
        self.url, self.course, self.log, self.pid = url.rstrip("/"), course, log, pid

    def session(self) -> requests.Session:
        return requests.Session()

    def form(self, session: requests.Session, page: str, **fields: str) -> requests.Response:
        """POST ``fields`` to the hub's form at ``page`` as a browser does (with the xsrf token)."""
        got = session.get(f"{self.url}/hub/{page}", timeout=60)
        match = re.search(r'name="_xsrf" value="([^"]+)"', got.text)
        assert match, f"/hub/{page}: no xsrf field\n{got.text[:2000]}"
        data = {**fields, "_xsrf": match.group(1)}  # no redirect followed: /hub/ would start a server
        return session.post(f"{self.url}/hub/{page}", data=data, timeout=60, allow_redirects=False)

    def sign_up(self, name: str) -> None:
        session = self.session()
        done = self.form(
            session, "signup", username=name, signup_password=PASSWORD, signup_password_confirmation=PASSWORD
        )
        assert re.search(r"sent to the admin|signup was successful", done.text), self.what(done)

    def sign_in(self, name: str) -> requests.Session:
        session = self.session()
        done = self.form(session, "login", username=name, password=PASSWORD)
        assert done.status_code == 302, self.what(done)  # signed in: off to the next page
        return session

    def api(self, session: requests.Session, method: str, path: str) -> requests.Response:
        xsrf = next((c.value for c in session.cookies if c.name == "_xsrf" and c.path.startswith("/hub")), "")
        return session.request(method, f"{self.url}/hub/api/{path}", headers={"X-XSRFToken": xsrf}, timeout=60)

    def start_server(self, session: requests.Session, name: str) -> None:
        done = self.api(session, "POST", f"users/{name}/server")
        assert done.status_code in (201, 202), self.what(done)

    def wait_ready(self, session: requests.Session, name: str) -> None:
        deadline = time.monotonic() + SPAWN_SECONDS
        while time.monotonic() < deadline:
            server = self.api(session, "GET", f"users/{name}").json().get("servers", {}).get("")
            if server and server.get("ready"):
                return
            time.sleep(1)
        pytest.fail(f"{name}'s server not ready after {SPAWN_SECONDS} s\n{self.tail()}")

    def wait_stopped(self, session: requests.Session, name: str) -> None:
        deadline = time.monotonic() + SPAWN_SECONDS
        while time.monotonic() < deadline:
            if not self.api(session, "GET", f"users/{name}").json().get("servers"):
                return
            time.sleep(0.5)
        pytest.fail(f"{name}'s server still listed after {SPAWN_SECONDS} s\n{self.tail()}")

    def tail(self) -> str:
        return "hub log:\n" + "\n".join(self.log.read_text(errors="replace").splitlines()[-60:])

    def what(self, response: requests.Response) -> str:
        return f"{response.status_code} {response.url}\n{response.text[-1500:]}\n{self.tail()}"


@pytest.fixture(scope="module")
def hub() -> Iterator[Hub]:
    remove_users()  # a previous run killed before its teardown
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
        remove_users()
        shutil.copy(log, Path(tempfile.gettempdir()) / "rstest_classroom_hub_last.log")  # for a failure's reader
        shutil.rmtree(course, ignore_errors=True)
        if python != sys.executable:  # the students' venv made for this run
            shutil.rmtree(Path(python).parent.parent, ignore_errors=True)


@pytest.fixture(scope="module")
def classroom(hub: Hub) -> dict[str, requests.Session]:
    """The teacher and four approved students, signed in."""
    for name in (ADMIN, *STUDENTS):
        hub.sign_up(name)
    unapproved = hub.form(hub.session(), "login", username=ALICE, password=PASSWORD)
    assert "has not been authorized by an administrator yet" in unapproved.text, hub.what(unapproved)
    teacher = hub.sign_in(ADMIN)
    for name in STUDENTS:  # the approve buttons of /hub/authorize
        page = teacher.get(f"{hub.url}/hub/authorize", timeout=60)
        assert f"authorize/{name}" in page.text, hub.what(page)
        assert teacher.get(f"{hub.url}/hub/authorize/{name}", timeout=60).status_code == 200
    return {ADMIN: teacher, **{name: hub.sign_in(name) for name in STUDENTS}}


def server_process(name: str) -> int:
    """The pid of the student's Jupyter server (the process of theirs running jupyterhub.singleuser)."""
    for pid in processes_of(pwd.getpwnam(name).pw_uid):
        try:
            if b"jupyterhub.singleuser" in Path(f"/proc/{pid}/cmdline").read_bytes():
                return pid
        except OSError:
            continue
    pytest.fail(f"no server process of {name}")


def environment(pid: int) -> dict[str, str]:
    entries = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
    return dict(entry.decode().split("=", 1) for entry in entries if b"=" in entry)


@pytest.fixture(scope="module")
def running(hub: Hub, classroom: dict[str, requests.Session]) -> dict[str, int]:
    """Both students' servers started (at once, as a class does): name → server pid."""
    for name in (ALICE, BOB):
        hub.start_server(classroom[name], name)
    for name in (ALICE, BOB):
        hub.wait_ready(classroom[name], name)
    return {name: server_process(name) for name in (ALICE, BOB)}


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
    assert {holder["user"]: int(domain) for domain, holder in held.items()} == domains


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


def test_stopping_a_server_leaves_no_process_of_the_student(hub, classroom, running):
    """Carol's server (started here: the others' stay up for the other tests, in any order)."""
    hub.start_server(classroom[CAROL], CAROL)
    hub.wait_ready(classroom[CAROL], CAROL)
    # Three servers hold the three domains: a fourth student is refused, told why.
    refused = hub.api(classroom[DAVE], "POST", f"users/{DAVE}/server")
    said = refused.text + hub.api(classroom[DAVE], "GET", f"users/{DAVE}/server/progress").text
    assert "all 3 ROS domains of this course server (202-204) are in use" in said, hub.what(refused)
    assert not hub.api(classroom[DAVE], "GET", f"users/{DAVE}").json().get("servers"), hub.tail()
    uid = pwd.getpwnam(CAROL).pw_uid
    # A process of Carol's outside her server's tree (as a world is: its own session).
    stray = subprocess.Popen(["setpriv", "--reuid", CAROL, "--regid", GROUP, "--init-groups", "setsid", "sleep", "600"])
    assert len(processes_of(uid)) >= 2
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
