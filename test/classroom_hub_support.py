"""What test/test_classroom_hub.py shares: the course server's test accounts and interpreter, the hub
spoken to over HTTP (the teacher's forms and API), and a student's path through it in headless
Chromium (sign up, sign in, JupyterLab's launcher, the studio, a world driven by the keys).

Selenium is imported only inside the browser helpers: the module loads without Chromium.
"""

from __future__ import annotations

import json
import os
import pwd
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import requests
from studio_browser_support import wait

from sim_tools.classroom.limits import remove_cgroup
from sim_tools.classroom.users import processes_of

PASSWORD = "a long classroom password 1"
SPAWN_SECONDS = 240.0  # ceilings: a busy 2-core machine starts several servers at once slowly
STUDIO_SECONDS = 300.0  # the proxy starts the studio on first use (its own ceiling: 120 s)
WORLD_SECONDS = 400.0  # three first worlds at once on a busy machine (a cold numba cache compiles)


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


def remove_users(names: tuple[str, ...], group: str) -> None:
    for name in names:
        try:
            uid = pwd.getpwnam(name).pw_uid
        except KeyError:
            continue
        subprocess.run(["pkill", "-KILL", "-U", str(uid)], capture_output=True)  # by uid: only theirs
        subprocess.run(["userdel", "-r", name], capture_output=True)
        remove_cgroup(name)
    subprocess.run(["groupdel", group], capture_output=True)


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


def commands_of(name: str) -> list[str]:
    """The command lines of every process of the Unix user ``name``."""
    commands = []
    for pid in processes_of(pwd.getpwnam(name).pw_uid):
        try:
            commands.append(Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode())
        except OSError:
            continue
    return commands


class Hub:
    """A running course server, spoken to over HTTP as a browser would."""

    def __init__(self, url: str, course: Path, log: Path, pid: int):
        self.url, self.course, self.log, self.pid = url.rstrip("/"), course, log, pid

    def form(self, session: requests.Session, page: str, **fields: str) -> requests.Response:
        """POST ``fields`` to the hub's form at ``page`` as a browser does (with the xsrf token)."""
        got = session.get(f"{self.url}/hub/{page}", timeout=60)
        match = re.search(r'name="_xsrf" value="([^"]+)"', got.text)
        assert match, f"/hub/{page}: no xsrf field\n{got.text[:2000]}"
        data: dict[str, str] = {**fields, "_xsrf": match.group(1)}  # no redirect followed: /hub/ would start a server
        return session.post(f"{self.url}/hub/{page}", data=data, timeout=60, allow_redirects=False)

    def sign_up(self, name: str) -> None:
        done = self.form(
            requests.Session(),
            "signup",
            username=name,
            signup_password=PASSWORD,
            signup_password_confirmation=PASSWORD,
        )
        assert re.search(r"sent to the admin|signup was successful", done.text), self.what(done)

    def sign_in(self, name: str) -> requests.Session:
        session = requests.Session()
        done = self.form(session, "login", username=name, password=PASSWORD)
        assert done.status_code == 302, self.what(done)  # signed in: off to the next page
        return session

    def api(self, session: requests.Session, method: str, path: str) -> requests.Response:
        xsrf = next((c.value or "" for c in session.cookies if c.name == "_xsrf" and c.path.startswith("/hub")), "")
        return session.request(method, f"{self.url}/hub/api/{path}", headers={"X-XSRFToken": xsrf}, timeout=60)

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


# ------------------------------------------------------------------------------ in Chromium


def body_text(driver: Any) -> str:
    """The page's visible text ('' while it is being replaced)."""
    from selenium.common.exceptions import WebDriverException

    try:
        return driver.execute_script("return document.body ? document.body.innerText : ''") or ""
    except WebDriverException:
        return ""


def fill_form(driver: Any, fields: dict[str, str], submit: str) -> None:
    """Type ``fields`` (element id → text) into the page's form and press its ``submit`` button."""
    from selenium.webdriver.common.by import By

    for element_id, text in fields.items():
        field = wait(driver, lambda d, i=element_id: d.find_element(By.ID, i), timeout=60.0)
        field.clear()
        field.send_keys(text)
    driver.find_element(By.ID, submit).click()


def sign_up_in_browser(driver: Any, hub: Hub, name: str) -> None:
    """NativeAuthenticator's sign-up form, filled in as a student does."""
    driver.get(f"{hub.url}/hub/signup")
    fields = {"username_input": name, "password_input": PASSWORD, "password_confirmation_input": PASSWORD}
    fill_form(driver, fields, "signup_submit")
    said = wait(
        driver,
        lambda d: re.search(r"sent to the admin|signup was successful|already exists", body_text(d)),
        timeout=60.0,
    )
    assert "already exists" not in said.group(0), body_text(driver)


def sign_in_in_browser(driver: Any, hub: Hub, name: str) -> None:
    """The hub's sign-in form: an approved student is then taken on to start their server."""
    driver.get(f"{hub.url}/hub/login")
    fill_form(driver, {"username_input": name, "password_input": PASSWORD}, "login_submit")


def in_lab(driver: Any, hub: Hub, name: str) -> bool:
    return driver.current_url.startswith(f"{hub.url}/user/{name}/lab")


def session_of(driver: Any) -> requests.Session:
    """A ``requests`` session holding every cookie of the browser's (the hub's and the server's)."""
    session = requests.Session()
    for cookie in driver.execute_cdp_cmd("Network.getAllCookies", {})["cookies"]:
        session.cookies.set(cookie["name"], cookie["value"], domain=cookie["domain"], path=cookie["path"])
    return session


def open_studio_from_lab(driver: Any, hub: Hub, name: str) -> None:
    """The student's JupyterLab, its launcher's "robot_sims studio" card clicked: the studio opens
    in a new tab (the entry's ``new_browser_tab``), which the driver then follows."""
    from selenium.webdriver.common.by import By

    if not in_lab(driver, hub, name):
        driver.get(f"{hub.url}/user/{name}/lab")
    card = "//div[contains(@class,'jp-LauncherCard') and contains(., 'robot_sims studio')]"
    before = set(driver.window_handles)
    wait(driver, lambda d: d.find_element(By.XPATH, card), timeout=STUDIO_SECONDS).click()
    opened = wait(driver, lambda d: set(d.window_handles) - before, timeout=60.0)
    driver.switch_to.window(opened.pop())


def studio_page_shown(driver: Any) -> bool:
    from selenium.webdriver.common.by import By

    return bool(driver.find_elements(By.CSS_SELECTOR, ".nicegui-content .studio-new-world"))


def start_world(driver: Any, namespace: str) -> None:
    """New world on the open floor in ``namespace``, started from the studio's page."""
    from studio_browser_support import find, type_into

    find(driver, ".studio-new-world").click()
    type_into(driver, ".studio-world-ns", namespace)
    find(driver, ".studio-start-world").click()  # the clicked button gives the focus back: keys drive


def robot_selected(driver: Any, namespace: str) -> bool:
    """The page follows the world it started: its robot selector shows the world's robot."""
    from selenium.common.exceptions import StaleElementReferenceException
    from selenium.webdriver.common.by import By

    shown = driver.find_elements(By.CSS_SELECTOR, ".studio-robot")
    try:
        return bool(shown) and namespace in shown[0].text
    except StaleElementReferenceException:  # redrawn meanwhile: asked again
        return False


def press(driver: Any, *keys: str) -> None:
    """Key presses on the page (not in a text field: the studio's driving keys)."""
    from selenium.webdriver.common.action_chains import ActionChains

    driver.execute_script("document.activeElement && document.activeElement.blur()")
    chain = ActionChains(driver)
    for key in keys:
        chain.send_keys(key)
    chain.perform()


def is_refusal(driver: Any, hub: Hub) -> bool:
    """Whether the page refuses the URL: the hub's 403 page, or its sign-in page."""
    return driver.current_url.startswith(f"{hub.url}/hub/login") or bool(re.search(r"\b403\b", body_text(driver)))


# ------------------------------------------------------------------------------ over ROS

LISTENER = r"""
import json, sys
import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data

rclpy.init()
node = Node(sys.argv[1])
say = lambda *words: print(*words, flush=True)
node.create_subscription(
    PoseStamped, sys.argv[2], lambda m: say("pose", m.pose.position.x, m.pose.position.y), qos_profile_sensor_data
)
node.create_timer(0.5, lambda: say("topics", json.dumps(sorted(t for t, _ in node.get_topic_names_and_types()))))
rclpy.spin(node)
"""
"""A student's own listener: every pose of ``argv[2]`` and, twice a second, the domain's topics."""


class StudentListener:
    """A ROS node run as the student, in their server's environment (their ``ROS_DOMAIN_ID``), as
    their terminal would run it. As the student, not root: Fast DDS's shared-memory segments are
    0644, so a world of the student's cannot write into a root listener's (root hears nothing)."""

    def __init__(self, name: str, group: str, topic: str) -> None:
        pid = server_process(name)
        self.env = environment(pid)
        self.domain = int(self.env["ROS_DOMAIN_ID"])
        python = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")[0].decode()
        user = ["setpriv", "--reuid", name, "--regid", group, "--init-groups"]
        self.process = subprocess.Popen(
            [*user, python, "-c", LISTENER, f"classroom_listener_{name}", topic],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=self.env,
            cwd=pwd.getpwnam(name).pw_dir,
        )
        self.poses: list[tuple[float, float]] = []
        self.topics: set[str] = set()
        self.other: list[str] = []  # anything else it printed (an error's traceback)
        self.reader = threading.Thread(target=self.read, daemon=True)
        self.reader.start()

    def read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            kind, _, rest = line.strip().partition(" ")
            if kind == "pose":
                x, y = rest.split()
                self.poses.append((float(x), float(y)))
            elif kind == "topics":
                self.topics = set(json.loads(rest))
            else:
                self.other.append(line)

    def until(self, predicate: Callable[[], bool], timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > deadline or self.process.poll() is not None:
                return predicate()
            time.sleep(0.05)
        return True

    def close(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.reader.join(10)

    def said(self) -> str:
        return "".join(self.other[-40:])
