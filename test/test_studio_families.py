"""The studio's families share one shape (:class:`studio.shell.app.Family`): what the entry point
lists is checked here at run time, and by mypy statically (each family is a ``Family[Client]``
whose client type must satisfy :class:`~studio.shell.app.FamilyClient`)."""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

import pytest

from studio.shell.workspace import Workspace


def test_every_family_the_entry_point_lists_has_the_one_shape():
    from studio.main import families
    from studio.shell.app import Family

    listed = families()
    assert [f.name for f in listed] == ["create", "arm", "replay", "simrobot"]
    for family in listed:
        assert isinstance(family, Family), family
        assert family.pages and all(callable(register) for register in family.pages), family.name
        assert family.client is None and family.worlds == {}  # nothing before the app starts
    registers = [register for family in listed for register in family.pages]
    assert len(set(registers)) == len(registers)  # each page belongs to one family


def test_every_family_s_client_is_made_on_the_studio_s_one_node_without_a_thread_of_its_own(tmp_path):
    from studio.main import families
    from studio.shell.app import Studio

    listed = families()
    studio = Studio(workspace=Workspace(tmp_path), controllers={}, families=tuple(listed))
    before = set(threading.enumerate())
    studio.start()
    try:
        assert studio.ros is not None
        clients = {f.name: f.client for f in listed}
        assert clients["replay"] is None  # Replay reads bags: it follows no world
        for name in ("create", "arm", "simrobot"):
            client = clients[name]
            assert client is not None and client.ros is studio.ros, name
        assert [t.name for t in set(threading.enumerate()) - before] == ["studio-ros"]  # one executor thread
        assert len(list(studio.ros.node.timers)) == 3  # each client's discovery round, on the one node
    finally:
        studio.shutdown()
    assert studio.ros is None and all(f.client is None for f in listed)


def test_a_page_finds_its_family_by_its_class_and_an_unlisted_one_is_an_error(tmp_path):
    from studio.arm.family import ArmFamily
    from studio.create.family import CreateFamily
    from studio.shell.app import Studio
    from studio.simrobot.family import SimrobotFamily

    create = CreateFamily()
    studio = Studio(workspace=Workspace(tmp_path), controllers={}, families=(create, SimrobotFamily()))
    assert studio.family(CreateFamily) is create
    with pytest.raises(LookupError, match="no ArmFamily"):
        studio.family(ArmFamily)


def sleeping_world(tmp_path: Path, label: str):
    from studio.shell.processes import Child

    child = Child(label, [sys.executable, "-c", "import time; print('ready', flush=True); time.sleep(60)"], tmp_path)
    deadline = time.monotonic() + 30.0
    while "ready" not in child.output:
        assert time.monotonic() < deadline and child.running
        time.sleep(0.01)
    return child


def test_the_namespace_checks_and_ctrl_c_see_the_worlds_of_every_family(tmp_path):
    from studio.main import families
    from studio.shell.app import Studio

    listed = families()
    studio = Studio(workspace=Workspace(tmp_path), controllers={}, families=tuple(listed))
    worlds = {}
    for family in listed:
        if family.name == "replay":
            continue
        ns = f"/{family.name}1"
        worlds[ns] = family.worlds[ns] = sleeping_world(tmp_path, f"{family.name}_world {ns}")
    try:
        for ns, child in worlds.items():  # no prefix to strip: a family's table is namespace → world
            assert f"{child.label} already runs in {ns}" in (studio.namespace_refusal(ns) or "")
        assert studio.free_namespace("arm") == "/arm2"
        studio.stop_children()  # what Ctrl-C and SIGHUP run
        assert not any(child.running for child in worlds.values())
        assert all(studio.namespace_refusal(ns) is None for ns in worlds)
    finally:
        for child in worlds.values():
            child.stop()


def test_a_family_callback_that_raises_is_reported_and_the_other_families_go_on(capfd):
    """The families share one executor thread: a bug in one's callback must not end it for all."""
    from studio.shell.ros import StudioRos

    ros = StudioRos()
    calls = {"bad": 0, "good": 0}

    def bad() -> None:
        calls["bad"] += 1
        raise RuntimeError("a bug in one family's round")

    def good() -> None:
        calls["good"] += 1

    ros.every(0.05, bad)
    ros.every(0.05, good)
    ros.spin()
    try:
        deadline = time.monotonic() + 60.0
        while calls["bad"] < 3 or calls["good"] < 10:  # the bad one raised again and again
            assert time.monotonic() < deadline and ros._thread.is_alive(), calls
            time.sleep(0.05)
    finally:
        ros.shutdown()
    err = capfd.readouterr()
    assert "a bug in one family's round" in err.err and "the studio goes on" in err.out
