"""The studio's m-file programs without a browser: the Octave command line it builds, the choices
it offers, and the two processes it runs (Octave and the bridge) started, ended and stopped
together. Octave's own part runs against a stand-in bridge (a socket speaking the protocol's first
line); the whole chain, with a world and the real bridge, is test_studio_matlab_browser.py."""

from __future__ import annotations

import asyncio
import contextlib
import shutil
import socket
import sys
import textwrap
import threading
import time
from dataclasses import replace
from pathlib import Path

import pytest
import yaml

from sim_runtime.errors import InputError
from sim_tools.matlab.paths import matlab_dir
from simrobot_sim.world_file import load_world
from studio.create.family import CreateFamily, create_family
from studio.create.matlab_program import (
    NO_OCTAVE,
    MatlabRun,
    bridge_command,
    bridge_ready,
    function_name,
    octave_command,
    program_choices,
    program_of,
    program_path,
    start_program,
)
from studio.shell.app import Studio
from studio.shell.processes import Child
from studio.shell.workspace import Workspace
from studio.simrobot.doc import WorldDraft, blank_walls, map_image
from studio.simrobot.editor_algorithms import algorithm_path, algorithm_value

needs_octave = pytest.mark.skipif(
    shutil.which("octave-cli") is None, reason="octave-cli not installed (CI installs it: .ci/run)"
)


def python_child(label: str, code: str) -> Child:
    """A stand-in process running ``code`` (its output kept as a studio child's)."""
    return Child(label, [sys.executable, "-u", "-c", textwrap.dedent(code)])


def fake_bridge() -> Child:
    """A stand-in bridge: says it listens, then prints ``SIGINT`` for each one it gets and ends
    0.3 s after the first (as the real one stops its robot first)."""
    return python_child(
        "bridge",
        """
        import signal, sys, time
        got = []
        signal.signal(signal.SIGINT, lambda *_: (got.append(1), print("SIGINT", flush=True)))
        print("matlab_bridge: listening on 127.0.0.1:47999 for /r1", flush=True)
        while not got or time.sleep(0.3):
            time.sleep(0.01)
        """,
    )


def listening_bridge() -> Child:
    """A stand-in bridge once it listens (as the studio starts Octave only then)."""
    bridge = fake_bridge()
    asyncio.run(bridge_ready(bridge))
    return bridge


def ended(child: Child, timeout: float = 10.0) -> bool:
    return child.wait(timeout) is not None


def test_the_octave_command_puts_the_toolbox_and_the_programs_folder_on_the_path_and_calls_it_with_the_handle():
    argv = octave_command(Path("/home/ana/it's lab/bump_turn.m"), 40123)
    assert argv[:-1] == ["octave-cli", "--no-gui", "--quiet", "--eval"]
    assert argv[-1] == (
        f"more off; addpath('{matlab_dir()}'); addpath('/home/ana/it''s lab'); "
        "serPort = CreateRobot(40123); bump_turn(serPort); clear serPort;"
    )
    assert (matlab_dir() / "CreateRobot.m").is_file()  # what `robot_sims matlab_path` prints


def test_the_bridge_serves_the_robots_namespace_on_any_free_port():
    assert bridge_command("/create2")[-4:] == ["--namespace", "/create2", "--port", "0"]
    assert bridge_command("")[-4:] == ["--namespace", "/", "--port", "0"]


@pytest.mark.parametrize("name", ["my-lab.m", "2lab.m", "lab.txt", "ünï.m"])
def test_a_file_name_matlab_cannot_call_as_a_function_is_refused_naming_the_file(name):
    with pytest.raises(InputError, match=f"{name}: not a MATLAB function's file name"):
        function_name(Path("/ws") / name)


def test_the_workspaces_m_files_are_offered_beside_the_controllers_and_named_back(tmp_path):
    (tmp_path / "labs").mkdir()
    (tmp_path / "labs" / "square.m").write_text("function square(serPort)\nend\n")
    (tmp_path / "box.map").write_text("")
    choices = program_choices(Workspace(tmp_path))
    assert choices == {"m:labs/square.m": "labs/square.m (Octave)"}
    assert program_of("m:labs/square.m") == "labs/square.m"
    assert program_of("create_bump_turn") is None and program_of(None) is None


def test_without_octave_starting_a_program_says_so_in_one_line_and_starts_nothing(tmp_path, monkeypatch):
    (tmp_path / "lab.m").write_text("function lab(serPort)\nend\n")
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    studio = Studio(workspace=Workspace(tmp_path), controllers={}, families=(CreateFamily(),))
    with pytest.raises(InputError) as error:
        asyncio.run(start_program(studio, "/r1", "lab.m"))
    assert str(error.value) == NO_OCTAVE and "\n" not in NO_OCTAVE
    assert create_family(studio).controllers == {}


def test_a_bridge_that_ends_before_listening_gives_its_error_line():
    bridge = python_child(
        "bridge", "print('matlab_bridge: error: --host 10.0.0.1: loopback only'); raise SystemExit(2)"
    )
    with pytest.raises(InputError, match=r"the MATLAB bridge ended: matlab_bridge: error: --host 10\.0\.0\.1"):
        asyncio.run(bridge_ready(bridge))


def test_the_bridges_port_is_read_from_its_listening_line():
    bridge = fake_bridge()
    try:
        assert asyncio.run(bridge_ready(bridge)) == 47999
    finally:
        bridge.stop()


def test_a_program_that_ends_ends_its_bridge_and_shows_octaves_error_not_its_call_stack():
    octave_says = [
        "moved 0.1",
        "error: the lab program gave up",
        "error: called from",
        "    lab at line 3 column 1",
        "error: ignoring const execution_exception& while preparing to exit",
    ]
    bridge = listening_bridge()
    run = MatlabRun(
        "lab.m (Octave)", [sys.executable, "-c", f"print(*{octave_says!r}, sep=chr(10)); exit(1)"], Path.cwd(), bridge
    )
    assert ended(run) and ended(bridge)  # nobody pressed Stop
    assert run.error_line() == "error: the lab program gave up"
    assert list(bridge.output).count("SIGINT") == 1


def test_a_program_that_returns_shows_its_last_line():
    bridge = listening_bridge()
    run = MatlabRun("lab.m (Octave)", [sys.executable, "-c", "print('done: 4 sides')"], Path.cwd(), bridge)
    assert ended(run) and ended(bridge)
    assert run.error_line() == "done: 4 sides"


def test_stop_kills_a_program_that_ignores_sigint_and_gives_the_bridge_one_sigint():
    bridge = listening_bridge()
    deaf = (
        "import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); print('looping', flush=1); time.sleep(60)"
    )
    run = MatlabRun("loop.m (Octave)", [sys.executable, "-c", deaf], Path.cwd(), bridge)
    while "looping" not in run.output:
        time.sleep(0.01)
    start = time.monotonic()
    run.stop()
    assert not run.running and not bridge.running
    assert time.monotonic() - start < 3.0
    assert list(bridge.output).count("SIGINT") == 1  # a second would interrupt the robot's stop


class StandInBridge:
    """A socket speaking the bridge protocol's greeting and answering every request ``ok``; the
    requests are kept."""

    def __init__(self) -> None:
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.requests: list[str] = []
        threading.Thread(target=self.serve, daemon=True).start()

    def serve(self) -> None:
        conn, _ = self.server.accept()
        with conn, conn.makefile("rw") as stream:
            stream.write("robot_sims-matlab 2 create /r1\n")
            stream.flush()
            with contextlib.suppress(ConnectionResetError):  # Octave ends without saying bye
                for line in stream:
                    ident, _, request = line.strip().partition(" ")  # "@1 Name args": one reply per id
                    self.requests.append(request)
                    stream.write(f"{ident} ok\n")
                    stream.flush()


@needs_octave
def test_octave_runs_the_program_with_the_connected_handle_and_its_error_reaches_the_page(tmp_path):
    (tmp_path / "gives_up.m").write_text(
        "function gives_up(serPort)\n"
        "  SetFwdVelAngVelCreate(serPort, 0.2, 0.5);\n"
        "  error('lab:gave_up', 'gave up after %d commands', 1);\n"
        "end\n"
    )
    stand_in, bridge = StandInBridge(), listening_bridge()
    program = tmp_path / "gives_up.m"
    run = MatlabRun("gives_up.m (Octave)", octave_command(program, stand_in.port), program.parent, bridge)
    assert ended(run, 60.0), list(run.output)
    assert run.error_line() == "error: gave up after 1 commands"
    name, *args = stand_in.requests[0].split()  # the toolbox's call, as the bridge would get it
    assert (name, [float(a) for a in args]) == ("SetFwdVelAngVelCreate", [0.2, 0.5])
    assert ended(bridge)


def test_the_simrobot_editor_writes_a_robots_algorithm_relative_to_the_world_file_and_loads_it_back(tmp_path):
    (tmp_path / "algs").mkdir()
    (tmp_path / "algs" / "alg2.m").write_text("function new = alg2(simrobot, matrix, step)\nnew = simrobot;\n")
    (tmp_path / "worlds").mkdir()
    doc = WorldDraft(walls=blank_walls(1.0, 0.6, 0.01))
    robot = doc.add_robot(0.3, 0.3)
    ws = Workspace(tmp_path)
    doc.robots[0] = replace(robot, algorithm=algorithm_path("m:algs/alg2.m", ws))
    map_image(doc.walls).save(tmp_path / "worlds" / "map.png")
    text = doc.world_yaml("map.png", tmp_path / "worlds")
    assert yaml.safe_load(text)["robots"][0]["algorithm"] == "../algs/alg2.m"  # the folder moves as one
    (tmp_path / "worlds" / "w.yaml").write_text(text)
    spec = load_world(tmp_path / "worlds" / "w.yaml")
    assert spec.robots == tuple(doc.robots) and spec.robots[0].controller is None
    assert algorithm_value(spec.robots[0].algorithm, ws) == "m:algs/alg2.m"  # what the editor shows


def test_an_algorithm_outside_the_workspace_is_shown_by_its_absolute_path(tmp_path):
    (tmp_path / "ws").mkdir()
    ws = Workspace(tmp_path / "ws")
    assert algorithm_value("/srv/course/alg2.m", ws) == "m:/srv/course/alg2.m"
    assert algorithm_path("m:/srv/course/alg2.m", ws) == "/srv/course/alg2.m"
    assert algorithm_path("m:alg2.m", ws) == str(tmp_path / "ws" / "alg2.m")


@pytest.mark.parametrize(
    ("text", "runs"),
    [
        ("% LAB1  Drive a square.\n\nfunction lab(serPort)\nend\n", True),
        ("%{\nfunction in a block comment\n%}\nfunction [a]=lab(serPort)\nend\n", True),
        ("SetFwdVelAngVelCreate(serPort, 0.2, 0)\n", False),  # a script: no serPort to hand it
        ("% a map saved under a .m name\nwall 0 0 1 1\n", False),
    ],
)
def test_only_a_function_file_is_run_as_a_program(tmp_path, text, runs):
    (tmp_path / "lab.m").write_text(text)
    if runs:
        assert program_path(Workspace(tmp_path), "lab.m") == tmp_path / "lab.m"
    else:
        with pytest.raises(InputError, match=r"lab\.m: not a function file: a program starts with function"):
            program_path(Workspace(tmp_path), "lab.m")


def test_a_program_missing_from_the_workspace_is_named(tmp_path):
    with pytest.raises(InputError, match=r"gone\.m: program file not found in the workspace"):
        program_path(Workspace(tmp_path), "gone.m")
