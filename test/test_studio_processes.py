"""The studio's children as processes: they die with the studio however it dies, their output
is kept and logged, the world limit and the Unix socket refuse what they should. Real processes
(a parent killed with SIGKILL, a socket another server holds); no browser, no ROS."""

from __future__ import annotations

import os
import signal
import socket
import stat
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import psutil
import pytest

from studio.shell import processes
from studio.shell.app import bind_unix_socket, max_worlds
from studio.shell.processes import Child, Processes

ROOT = Path(__file__).resolve().parent.parent


def studio_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "studio", *args]


def test_a_child_dies_when_the_studio_is_killed_outright(tmp_path):
    # A stand-in studio: it starts a child the way the pages do (from a short-lived thread, as a
    # handler may run), says its pid, and waits to be killed.
    script = textwrap.dedent(
        """
        import sys, threading, time
        from studio.shell.processes import Child
        made = []
        thread = threading.Thread(target=lambda: made.append(Child("sleeper", ["sleep", "600"])))
        thread.start(); thread.join()
        time.sleep(1.0)  # the forking thread is gone: the child must still run
        print(made[0].process.pid, made[0].running, flush=True)
        time.sleep(600)
        """
    )
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, cwd=ROOT)
    assert parent.stdout is not None
    pid_text, running = parent.stdout.readline().split()
    assert running == "True"  # not killed when the thread that asked for it ended
    child = psutil.Process(int(pid_text))
    assert child.is_running() and child.status() != psutil.STATUS_ZOMBIE
    parent.kill()  # SIGKILL: no handler of the studio's runs
    parent.wait(timeout=10)
    child.wait(timeout=10)  # the kernel's parent-death signal; psutil.TimeoutExpired if it lived on


def test_a_childs_output_is_kept_and_written_to_its_log_file(tmp_path, monkeypatch):
    monkeypatch.setattr(processes, "PROCESSES", Processes(log_folder=tmp_path / ".robot_sims" / "output"))
    child = Child("talker /t", [sys.executable, "-c", "print('one'); import sys; print('two', file=sys.stderr)"])
    assert child.wait(30.0) == 0
    child._reader.join(timeout=10.0)
    assert list(child.output) == ["one", "two"] and child.line_count == 2
    assert child.log_file is not None and child.log_file.parent == tmp_path / ".robot_sims" / "output"
    assert "talker_t" in child.log_file.name
    text = child.log_file.read_text().splitlines()
    assert text[1:] == ["one", "two", "(ended: exit status 0)"] and text[0].startswith("$ ")
    assert stat.S_IMODE(child.log_file.parent.stat().st_mode) == 0o700
    assert processes.PROCESSES.listed() == [child]


def test_ended_children_beyond_the_kept_number_are_forgotten_the_running_kept(monkeypatch):
    monkeypatch.setattr(processes, "ENDED_KEPT", 2)
    table = Processes()
    monkeypatch.setattr(processes, "PROCESSES", table)
    runner = Child("runner", ["sleep", "60"])
    try:
        ended = [Child(f"quick{n}", ["true"]) for n in range(4)]
        for child in ended:
            child.wait(30.0)
        Child("last", ["true"]).wait(30.0)
        labels = [child.label for child in table.listed()]
        assert "runner" in labels and len(labels) <= 4 and "quick0" not in labels
    finally:
        runner.stop(1.0)


def test_the_world_limit_refuses_with_a_sentence_naming_the_setting():
    table = Processes(max_worlds=2)
    assert table.world_refusal(1) is None
    refusal = table.world_refusal(2)
    assert refusal is not None and "at most 2 worlds" in refusal and "ROBOT_SIMS_MAX_WORLDS" in refusal
    assert Processes().world_refusal(50) is None  # no limit set


def test_the_world_limit_comes_from_the_option_else_the_environment(monkeypatch):
    monkeypatch.setenv("ROBOT_SIMS_MAX_WORLDS", "3")
    assert max_worlds(None) == 3
    assert max_worlds(1) == 1
    monkeypatch.delenv("ROBOT_SIMS_MAX_WORLDS")
    assert max_worlds(None) is None


@pytest.mark.parametrize(
    ("args", "env", "said"),
    [
        (["--max-worlds", "0"], {}, "--max-worlds 0"),
        ([], {"ROBOT_SIMS_MAX_WORLDS": "lots"}, "ROBOT_SIMS_MAX_WORLDS 'lots'"),
    ],
)
def test_a_bad_world_limit_is_refused_before_the_studio_starts(tmp_path, args, env, said):
    done = subprocess.run(
        studio_command("--workspace", str(tmp_path), *args),
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, **env},
        timeout=120,
    )
    assert done.returncode == 2
    assert said in done.stderr and "1 or more" in done.stderr


def test_the_unix_socket_is_its_owners_only_and_a_stale_one_is_replaced(tmp_path):
    path = tmp_path / "new" / "studio.sock"
    first = bind_unix_socket(str(path))
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE(path.parent.stat().st_mode) == 0o700
    first.close()  # nobody listens: a stale socket file is left
    second = bind_unix_socket(str(path))
    second.listen(1)
    try:
        with pytest.raises(OSError, match="another server listens"):
            bind_unix_socket(str(path))
    finally:
        second.close()
    (tmp_path / "plain").write_text("x")
    with pytest.raises(OSError, match="not a socket"):
        bind_unix_socket(str(tmp_path / "plain"))


def test_a_studio_on_a_unix_socket_serves_there_and_names_it_instead_of_a_url(tmp_path):
    sock = tmp_path / "s" / "studio.sock"
    env = {**os.environ, "JUPYTERHUB_SERVICE_PREFIX": "/user/alice/"}
    env.pop("ROBOT_SIMS_PROXY_PATH", None)
    env.pop("PYTEST_CURRENT_TEST", None)
    log = tmp_path / "studio.log"
    with log.open("w") as out:
        studio = subprocess.Popen(
            studio_command("--workspace", str(tmp_path), "--unix-socket", str(sock)),
            stdout=out,
            stderr=subprocess.STDOUT,
            cwd=ROOT,
            env=env,
        )
    try:
        deadline = time.monotonic() + 120.0
        answer = b""
        while not answer.startswith(b"HTTP/1.1 200"):
            assert studio.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.2)
            try:
                with socket.socket(socket.AF_UNIX) as client:
                    client.settimeout(30.0)
                    client.connect(str(sock))
                    client.sendall(b"GET / HTTP/1.1\r\nHost: studio\r\nConnection: close\r\n\r\n")
                    answer = client.recv(200)
            except OSError:
                continue
        first = log.read_text().splitlines()[0]
        assert f"listening on the Unix socket {sock}" in first and "open /user/alice/robot_sims/" in first
        assert "http://" not in first
        listening = [c for c in psutil.Process(studio.pid).net_connections("tcp") if c.status == psutil.CONN_LISTEN]
        assert listening == []
    finally:
        studio.send_signal(signal.SIGINT)
        studio.wait(timeout=60)
    assert not sock.exists()  # removed on the way out


def test_the_spawner_forks_from_one_thread_whoever_asks():
    names = []

    def start() -> None:
        child = Child("t", ["true"])
        child.wait(30.0)
        names.append(processes.SPAWNER._thread.name if processes.SPAWNER._thread else "")

    threads = [threading.Thread(target=start) for _ in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert names == ["studio-spawner"] * 3
