"""The studio in JupyterLab, as a student meets it: a real Jupyter server (token authentication,
jupyter-server-proxy, no hub) configured with studio/jupyter.py's entry, the studio opened through
it in headless Chromium, a world started from the page, its output on the Output page; the studio
reachable only through the server (a Unix socket, no TCP port); everything gone once the server is
killed outright.

The tests run in order on one server and one browser; the last one kills the server."""

from __future__ import annotations

import json
import os
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from studio_browser_support import NO_CHROMIUM

if NO_CHROMIUM:
    pytest.skip(NO_CHROMIUM, allow_module_level=True)

import psutil
from selenium.common.exceptions import StaleElementReferenceException
from studio_browser_support import (
    ROOT,
    find,
    free_port,
    new_browser,
    open_page,
    studio_domain,
    studio_env,
    type_into,
    wait,
)

from studio.jupyter import NAME, setup_studio

DOMAIN = studio_domain(57)
TOKEN = "robot-sims-test-token"
NS = "/jup"

CONFIG = f"""
from studio.jupyter import setup_studio

# The proxy alone (JupyterLab's launcher reads the proxy's servers-info, asked below); root in CI.
c.ServerApp.jpserver_extensions = {{
    "jupyter_server_proxy": True, "jupyterlab": False, "jupyter_lsp": False, "notebook_shim": False
}}
c.ServerApp.allow_root = True
c.ServerProxy.servers = {{{NAME!r}: setup_studio()}}
c.IdentityProvider.token = {TOKEN!r}
c.ServerApp.open_browser = False
"""


class KeepRedirects(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *_args, **_kwargs):
        return None


NO_REDIRECTS = urllib.request.build_opener(KeepRedirects)


class JupyterServer:
    """A ``jupyter server`` subprocess on a free port, its root folder the student's workspace."""

    def __init__(self, root: Path, config_dir: Path) -> None:
        self.root = root
        self.port = free_port()
        self.log = config_dir / "jupyter.log"
        (config_dir / "jupyter_server_config.py").write_text(CONFIG)
        env = {
            **studio_env(DOMAIN),
            "JUPYTER_CONFIG_DIR": str(config_dir),
            "JUPYTER_RUNTIME_DIR": str(config_dir / "runtime"),
            "PYTHONPATH": str(ROOT),  # the config imports studio.jupyter from this tree
        }
        env.pop("ROBOT_SIMS_WORKSPACE", None)
        env["ROBOT_SIMS_MAX_WORLDS"] = "1"  # as a classroom's spawner sets it
        with self.log.open("w") as out:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "jupyter_server", f"--port={self.port}", f"--ServerApp.root_dir={root}"],
                stdout=out,
                stderr=subprocess.STDOUT,
                cwd=root,
                env=env,
            )
        deadline = time.monotonic() + 60.0
        while True:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1.0).close()
                break
            except OSError:
                assert self.process.poll() is None and time.monotonic() < deadline, self.log.read_text()
                time.sleep(0.1)

    def url(self, path: str, token: bool = True) -> str:
        joined = "&" if "?" in path else "?"
        return f"http://127.0.0.1:{self.port}{path}" + (f"{joined}token={TOKEN}" if token else "")

    def get(self, path: str, token: bool = True) -> tuple[int, str]:
        """The status and body of a GET, redirects not followed (a login page is not the studio)."""
        try:
            with NO_REDIRECTS.open(self.url(path, token), timeout=180.0) as answer:
                return answer.status, answer.read().decode("utf-8", "replace")
        except urllib.error.HTTPError as err:
            return err.code, ""

    def studio(self) -> psutil.Process:
        """The studio the server's proxy started (its one child running ``-m studio``)."""
        for child in psutil.Process(self.process.pid).children():
            if "studio" in child.cmdline() and "--unix-socket" in child.cmdline():
                return child
        pytest.fail(f"no studio under the Jupyter server:\n{self.log.read_text()[-3000:]}")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            self.process.wait(timeout=30)
        print(self.log.read_text()[-5000:])


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    root = tmp_path_factory.mktemp("student_home")
    jupyter = JupyterServer(root, Path(tempfile.mkdtemp(prefix="jupyter_cfg_")))
    try:
        yield jupyter
    finally:
        jupyter.stop()


@pytest.fixture(scope="module")
def browser():
    with new_browser() as driver:
        yield driver


def test_the_entry_runs_this_interpreters_studio_on_the_proxys_socket_with_a_long_start_timeout(monkeypatch):
    monkeypatch.setenv("ROBOT_SIMS_WORKSPACE", "/srv/course/{alice}")
    entry = setup_studio()
    command = entry["command"]("/tmp/jsp-x/socket")
    assert command[:3] == [sys.executable, "-m", "studio"]
    assert command[command.index("--unix-socket") + 1] == "/tmp/jsp-x/socket"
    # The proxy runs str.format on each word: the folder's braces come through as they are.
    assert command[command.index("--workspace") + 1].format() == "/srv/course/{alice}"
    assert "--exit-with-parent" in command
    assert entry["unix_socket"] is True and entry["timeout"] >= 120
    assert entry["launcher_entry"]["title"] == "robot_sims studio"
    assert "port" not in entry  # no TCP port, fixed or not
    assert entry["environment"]("/user/alice/")["ROBOT_SIMS_PROXY_PATH"] == "/user/alice/robot_sims/"
    # What a Jupyter server loads at start stays light: no NiceGUI, no rclpy.
    probe = "import sys, studio.jupyter; print(sorted(m for m in ('nicegui', 'rclpy') if m in sys.modules))"
    loaded = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=ROOT, check=True)
    assert loaded.stdout.strip() == "[]"


def test_the_launcher_lists_the_studio(server):
    status, info = server.get("/server-proxy/servers-info")
    assert status == 200
    entries = {entry["name"]: entry for entry in json.loads(info)["server_processes"]}
    assert entries[NAME]["launcher_entry"]["title"] == "robot_sims studio"
    assert entries[NAME]["launcher_entry"]["path_info"] == f"{NAME}/"


def test_the_studio_page_comes_through_the_server_and_only_with_its_token(server):
    status, page = server.get(f"/{NAME}/")
    assert status == 200, server.log.read_text()[-3000:]
    assert "robot_sims studio" in page
    status, _page = server.get(f"/{NAME}/", token=False)
    assert status in (302, 403)  # to the login page, or refused: never the studio


def test_the_studio_listens_on_a_private_unix_socket_and_no_tcp_port(server):
    studio = server.studio()
    assert [c for c in studio.net_connections(kind="tcp") if c.status == psutil.CONN_LISTEN] == []
    # The proxy's socket (psutil gives Unix sockets no listening state): in its own temporary folder.
    sockets = {c.laddr for c in studio.net_connections(kind="unix") if "jupyter-server-proxy-" in (c.laddr or "")}
    assert len(sockets) == 1, sockets
    path = Path(sockets.pop())
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE(path.parent.stat().st_mode) == 0o700
    assert studio.cwd() and Path(studio.cmdline()[studio.cmdline().index("--workspace") + 1]) == server.root


def text_of(driver, css: str) -> str:
    """An element's text, '' while the page is redrawing it (a stale element)."""
    try:
        return find(driver, css).text
    except StaleElementReferenceException:
        return ""


def controller_started(driver) -> bool:
    """Start pressed (again, every few seconds, until the page has selected the new robot)."""
    if "running" in text_of(driver, ".studio-controller-state"):
        return True
    now = time.monotonic()
    if now - getattr(controller_started, "pressed", 0.0) > 3.0:
        controller_started.pressed = now  # type: ignore[attr-defined]
        find(driver, ".studio-controller-start").click()
    return False


def test_a_world_started_from_the_page_through_the_proxy_runs_and_its_output_is_shown(server, browser):
    open_page(browser, server.url(f"/{NAME}/"))
    find(browser, ".studio-new-world").click()
    type_into(browser, ".studio-world-ns", NS)
    find(browser, ".studio-start-world").click()
    # The page follows the world (its websocket works through the proxy): the robot selector has it.
    wait(browser, lambda d: NS in text_of(d, ".studio-robot"), timeout=300.0)  # a first start compiles
    wait(browser, controller_started, timeout=60.0)
    # A second world is one more than the hub allows this student: refused, saying why.
    type_into(browser, ".studio-world-ns", "/another")
    find(browser, ".studio-start-world").click()
    wait(browser, lambda d: "at most 1 world at once" in text_of(d, ".studio-world-error"), timeout=30.0)
    open_page(browser, server.url(f"/{NAME}/output"))  # the newest first: the controller
    wait(browser, lambda d: "create_bump_turn" in text_of(d, ".studio-output-select"), timeout=30.0)
    world = next(p for p in server.studio().children() if "create_world" in p.cmdline())
    open_page(browser, server.url(f"/{NAME}/output?pid={world.pid}"))
    wait(browser, lambda d: f"create_world {NS}" in text_of(d, ".studio-output-select"), timeout=30.0)
    wait(browser, lambda d: "ready" in text_of(d, ".studio-output-text"), timeout=30.0)
    logs = list((server.root / ".robot_sims" / "output").glob("*create_world*.log"))
    assert len(logs) == 1 and "ready" in logs[0].read_text()
    assert str(logs[0]) in find(browser, ".studio-output-file").text


def test_a_jupyter_server_killed_outright_takes_the_studio_and_its_worlds_with_it(server):
    studio = server.studio()
    family = [studio, *studio.children(recursive=True)]
    commands = [" ".join(p.cmdline()) for p in family[1:]]
    assert any("create_world" in c for c in commands) and any("create_bump_turn" in c for c in commands), commands
    os.kill(server.process.pid, signal.SIGKILL)
    server.process.wait(timeout=10)
    _gone, alive = psutil.wait_procs(family, timeout=30.0)
    assert alive == [], [p.cmdline() for p in alive]


def test_a_jupyter_server_stopped_with_sigterm_stops_the_studio_cleanly(tmp_path):
    jupyter = JupyterServer(tmp_path, Path(tempfile.mkdtemp(prefix="jupyter_cfg_")))
    try:
        status, _page = jupyter.get(f"/{NAME}/")
        assert status == 200, jupyter.log.read_text()[-3000:]
        studio = jupyter.studio()
        jupyter.process.terminate()  # as the hub stops a server; the proxy passes SIGTERM on
        jupyter.process.wait(timeout=60)
        studio.wait(timeout=60)
        lines = jupyter.log.read_text()
        assert "robot_sims studio: stopping what it started" in lines  # its own shutdown ran
    finally:
        jupyter.stop()
