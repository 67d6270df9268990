"""A SIMROBOT robot's memory, as the editor's Memory menu handles it: loaded from a MAT or text
file in the workspace, written into the world file, read by the robot's algorithm with readmem
from its first step, and saved to disk again."""

from __future__ import annotations

import shutil
from dataclasses import replace

import numpy as np
import pytest

from sim_runtime.errors import InputError
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import load_world
from studio.shell.workspace import Workspace
from studio.simrobot.doc import WorldDraft, blank_walls, map_image
from studio.simrobot.memory import load_memory, memory_info, save_memory

needs_octave = pytest.mark.skipif(
    shutil.which("octave-cli") is None and shutil.which("octave") is None,
    reason="GNU Octave is not installed here (apt install octave); CI runs these tests",
)


def test_memory_loads_from_a_text_or_mat_file_and_saves_back_the_same_numbers(tmp_path):
    ws = Workspace(tmp_path)
    (tmp_path / "mem.txt").write_text("1 2.5 3\n4, 5, 6\n")
    memory = load_memory(ws, "mem.txt")
    assert memory == ((1.0, 2.5, 3.0), (4.0, 5.0, 6.0)) and memory_info(memory) == "memory: 2 x 3 double (48 bytes)"
    save_memory(ws, "copy.mat", memory, overwrite=False)
    assert load_memory(ws, "copy.mat") == memory
    save_memory(ws, "copy.txt", memory, overwrite=False)
    assert load_memory(ws, "copy.txt") == memory
    with pytest.raises(InputError, match=r"copy\.txt: file exists \(tick 'overwrite' to replace it\)"):
        save_memory(ws, "copy.txt", memory, overwrite=False)
    assert memory_info(None) == "memory: empty"


@pytest.mark.parametrize(
    ("name", "content", "said"),
    [
        ("words.txt", "left right\n", "words.txt: not rows of numbers .*: write one row of numbers a line"),
        ("fake.mat", "not a mat-file", r"fake\.mat: not a MAT-file: save it in MATLAB or Octave"),
        ("missing.txt", None, "missing.txt: no such file in the workspace"),
    ],
)
def test_a_memory_file_that_cannot_be_read_is_refused_saying_what_to_do(tmp_path, name, content, said):
    if content is not None:
        (tmp_path / name).write_text(content)
    with pytest.raises(InputError, match=said):
        load_memory(Workspace(tmp_path), name)


def test_a_mat_file_without_mem_says_how_to_save_one(tmp_path):
    from scipy.io import savemat

    savemat(tmp_path / "other.mat", {"data": np.eye(2)})
    with pytest.raises(InputError, match=r"other\.mat: holds no variable mem: save the memory as mem"):
        load_memory(Workspace(tmp_path), "other.mat")


def memory_world(tmp_path, memory) -> WorldDraft:
    doc = WorldDraft(walls=blank_walls(1.0, 0.6, 0.01), dt=0.1)
    robot = doc.add_robot(0.5, 0.3)
    (tmp_path / "alg_mem.m").write_text(
        "function new = alg_mem(simrobot, matrix, step)\n"
        "m = readmem(simrobot);\n"
        "simrobot = setvel(simrobot, [m(1, 1) m(2, 2)]);\n"  # the wheels turn as the memory says
        "new = simrobot;\n"
    )
    doc.robots[0] = replace(robot, algorithm=str(tmp_path / "alg_mem.m"), memory=memory)
    map_image(doc.walls).save(tmp_path / "map.png")
    return doc


@needs_octave
def test_the_memory_the_editor_saves_is_what_the_robots_algorithm_reads_first(tmp_path):
    from simrobot_sim.matlab_alg import OctaveAlgorithms

    (tmp_path / "mem.txt").write_text("0.25 0\n0 0.75\n")
    doc = memory_world(tmp_path, load_memory(Workspace(tmp_path), "mem.txt"))
    (tmp_path / "w.yaml").write_text(doc.world_yaml("map.png", tmp_path))
    assert "memory:" in (tmp_path / "w.yaml").read_text()
    spec = load_world(tmp_path / "w.yaml")
    assert spec.robots[0].memory == ((0.25, 0.0), (0.0, 0.75))
    world = SimrobotWorld(spec)
    reports: list[str] = []
    algorithms = OctaveAlgorithms(world, {0: tmp_path / "alg_mem.m"}, report=reports.append)
    try:
        algorithms.run()
    finally:
        algorithms.close()
    assert reports == []
    assert world.vel[0].tolist() == [0.25, 0.75]
