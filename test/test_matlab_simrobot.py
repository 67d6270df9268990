"""The original's SIMROBOT algorithm m-files driving our worlds through GNU Octave (oct2py)."""

from __future__ import annotations

import math
import os
import shutil
import signal
from pathlib import Path

import numpy as np
import pytest

from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from simrobot_sim.avoid import STRAIGHT, THRESHOLD, TURN
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec, load_world

PROGRAMS = Path(__file__).parent / "matlab_programs"
#: The shipped alg2-style algorithm (config/simrobot/demo_matlab.yaml runs it on every robot).
ALG2 = config_path("simrobot/avoid_alg.m")
needs_octave = pytest.mark.skipif(
    shutil.which("octave-cli") is None and shutil.which("octave") is None,
    reason="GNU Octave is not installed here (apt install octave); CI runs these tests",
)


@pytest.fixture(scope="module")
def octave():
    """One Octave session for the module's model-level runs (each run resets it)."""
    from simrobot_sim.matlab_alg import start_octave

    session = start_octave()
    yield session
    session.exit()


def demo_world() -> SimrobotWorld:
    return SimrobotWorld(load_world(config_path("simrobot/demo.yaml")))


def run_mfiles(
    world: SimrobotWorld, files: dict[int, Path], steps: int, octave, reports: list[str], output=print
) -> np.ndarray:
    from simrobot_sim.matlab_alg import OctaveAlgorithms

    algorithms = OctaveAlgorithms(world, files, report=reports.append, session=octave, output=output)
    for _ in range(steps):
        algorithms.run()
        world.step()
    return world.history.array()


def run_python_twin(world: SimrobotWorld, robots: list[int], steps: int) -> np.ndarray:
    # simrobot_sim/avoid.py's rule on the same readings, applied at the same steps
    for _ in range(steps):
        for i in robots:
            dist, _num = world.nearest(i)
            world.set_wheel_speeds(i, *(TURN if dist < THRESHOLD else STRAIGHT))
        world.step()
    return world.history.array()


@needs_octave
def test_an_alg2_style_m_file_drives_four_robots_exactly_as_its_python_twin_and_twice_the_same(octave):
    files = dict.fromkeys(range(4), ALG2)
    reports: list[str] = []
    first = run_mfiles(demo_world(), files, 300, octave, reports)
    second = run_mfiles(demo_world(), files, 150, octave, reports)  # half as long: the same first half
    twin = run_python_twin(demo_world(), list(range(4)), 300)
    assert reports == []
    assert first.shape == (301, 4, 3)
    assert np.array_equal(first[:151], second)
    assert np.array_equal(first, twin)
    assert np.all(np.hypot(*(first[-1, :, :2] - first[0, :, :2]).T) > 0.3)  # every robot went somewhere
    assert np.any(np.abs(np.diff(first[:, :, 2], axis=0)) > 0.05)  # and turned at obstacles


@needs_octave
def test_an_algorithm_that_raises_stops_its_robot_is_reported_once_and_the_world_goes_on(octave):
    reports: list[str] = []
    failing = {0: PROGRAMS / "simrobot_fails.m", 1: ALG2, 2: ALG2, 3: ALG2}
    tracks = run_mfiles(demo_world(), failing, 12, octave, reports)
    twin = run_python_twin(demo_world(), [1, 2, 3], 12)
    assert len(reports) == 1
    assert "'r1'" in reports[0] and "simrobot_fails.m" in reports[0] and "step 5" in reports[0]
    assert "no_such_function_here" in reports[0] and "the robot stops" in reports[0]
    # r1 drove 4 steps at 0.5 cm/step, then stood still; the others kept going as their twin
    assert tracks[4, 0, 1] == pytest.approx(tracks[0, 0, 1] + 0.02)
    assert np.array_equal(tracks[4:, 0], np.repeat(tracks[4:5, 0], 9, axis=0))
    assert np.array_equal(tracks[:, 1:], twin[:, 1:])


@needs_octave
def test_the_robot_functions_answer_in_the_originals_units(octave):
    walls = np.zeros((120, 80), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    sensors = (
        SensorSpec("front", "ultrasonic", position=(0.05, 0.0), range=0.3, rays=5),
        SensorSpec("scan", "laser", position=(0.05, 0.0), beamwidth=math.radians(90), range=2.0, rays=3),
    )
    robot = RobotSpec("probe", (1.5, 2.4), heading=math.radians(-90), sensors=sensors)
    world = SimrobotWorld(WorldSpec(walls=walls, robots=(robot,), origin=(1.0, 2.0)))
    printed: list[str] = []
    tracks = run_mfiles(world, {0: PROGRAMS / "simrobot_probe.m"}, 5, octave, [], printed.append)
    assert printed == [f"probe step {k}" for k in range(1, 6)]  # what it printed, line by line
    octave.eval("global SIMROBOT_WORLD_; probe_memory = readmem(SIMROBOT_WORLD_.robots{1});", nout=0)
    memory = octave.pull("probe_memory")
    first = memory[0, 0] if memory.ndim == 2 else memory[0]
    assert first["name"] == "probe" and first["num"] == 2 and first["power"] == 1
    assert np.allclose(np.ravel(first["pos"]), [50.0, 40.0])  # cells from the map's corner
    assert first["head"] == pytest.approx(270.0)
    assert first["dist"] == 999999 and first["obstacle"] == 0  # nothing within 30 cm ahead
    ranges, values = world.ranges(1)  # the laser of the last step: every ray reaches a wall
    assert np.ravel(first["laser_nums"]).tolist() == [1.0, 1.0, 1.0]
    assert np.ravel(first["size"]).tolist() == [120.0, 80.0]
    # the matrix it got at step 5 is the world's (after the robot's turns), uint8 as the original's
    last = memory[0, -1] if memory.ndim == 2 else memory[-1]
    assert last["class"] == "uint8" and np.ravel(last["own_cells"]).tolist() != np.ravel(first["own_cells"]).tolist()
    assert np.ravel(last["own_cells"]).tolist() == (np.flatnonzero(world.grid.ravel(order="F") == 2) + 1).tolist()
    assert np.ravel(first["inv"]).tolist() == [-0.5, 2.5]  # (1 -+ 3 * 0.5) / 1
    assert "no sensor 'nosuch'" in first["unknown"] and "front, scan" in first["unknown"]
    # it turned in place at [-0.5 0.5] (1/6 rad a step) in steps 1 and 2; step 3 switched it off first
    assert np.allclose(np.diff(tracks[:3, 0, 2]), 1 / 6, atol=1e-6) and np.array_equal(tracks[2, 0], tracks[5, 0])
    assert not world.power[0] and len(ranges) == 3 and np.all(values == 1)


def world_yaml(tmp_path: Path, robot_fields: str) -> Path:
    path = tmp_path / "w.yaml"
    path.write_text(
        f"map: {config_path('simrobot/demo_map.png')}\nrobots:\n  - {{name: a, position: [1.3, 1.55]{robot_fields}}}\n"
    )
    return path


def test_a_world_file_names_an_algorithm_m_file_relative_to_itself(tmp_path):
    from studio.simrobot.doc import robot_entry

    (tmp_path / "mine.m").write_text("function new = mine(simrobot, matrix, step)\nnew = simrobot;\n")
    spec = load_world(world_yaml(tmp_path, ", algorithm: mine.m"))
    assert spec.robots[0].algorithm == str((tmp_path / "mine.m").resolve())
    assert robot_entry(spec.robots[0])["algorithm"] == spec.robots[0].algorithm  # the studio saves it back
    assert load_world(world_yaml(tmp_path, "")).robots[0].algorithm is None


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        (", algorithm: missing.m", "robots[0] ('a').algorithm: '"),
        (", algorithm: mine.py", "expected the path of an m-file"),
        (", algorithm: mine.m, controller: avoid", "a controller or an algorithm, not both"),
    ],
)
def test_a_bad_algorithm_entry_is_an_input_error_naming_the_robot(tmp_path, fields, message):
    (tmp_path / "mine.m").write_text("function new = mine(simrobot, matrix, step)\nnew = simrobot;\n")
    with pytest.raises(InputError, match=None) as err:
        load_world(world_yaml(tmp_path, fields))
    assert message in str(err.value) and "w.yaml" in str(err.value)


@needs_octave
def test_an_endless_algorithm_is_interrupted_and_stops_its_robot_while_the_others_go_on(octave):
    from simrobot_sim.matlab_alg import OctaveAlgorithms

    world = demo_world()
    reports: list[str] = []
    files = {0: ALG2, 1: PROGRAMS / "simrobot_endless.m", 2: ALG2}
    algorithms = OctaveAlgorithms(world, files, report=reports.append, session=octave, timeout=1.0)
    for _ in range(6):
        algorithms.run()
        world.step()
    assert len(reports) == 1 and "'r2'" in reports[0] and "no answer within 1 s" in reports[0]
    assert "step 3" in reports[0]
    tracks = world.history.array()
    assert np.array_equal(tracks[2:, 1], np.repeat(tracks[2:3, 1], 5, axis=0))  # r2 stopped at step 3
    assert tracks[6, 0, 1] > tracks[3, 0, 1]  # r1 (heading north) kept driving
    assert algorithms.active.tolist() == [True, False, True, False]


@needs_octave
def test_a_killed_octave_stops_every_algorithm_robot_once_and_the_world_steps_on():
    from simrobot_sim.matlab_alg import OctaveAlgorithms

    world = demo_world()
    reports: list[str] = []
    algorithms = OctaveAlgorithms(world, dict.fromkeys(range(4), ALG2), report=reports.append)
    algorithms.run()
    world.step()
    os.kill(int(algorithms.octave.feval("getpid")), signal.SIGKILL)
    for _ in range(3):
        algorithms.run()
        world.step()
    assert len(reports) == 1 and "Octave failed at step 2" in reports[0] and "'r1', 'r2', 'r3', 'r4' stop" in reports[0]
    tracks = world.history.array()
    assert np.array_equal(tracks[1], tracks[4]) and not np.array_equal(tracks[0], tracks[1])
    assert world.step_count == 4 and algorithms.octave is None


@needs_octave
def test_a_world_file_robot_with_an_algorithm_is_driven_by_it_in_lockstep_from_the_world_node(
    executor, tmp_path, capfd
):
    from rclpy.parameter import Parameter

    from sim_runtime.run import spin_steps
    from simrobot_sim.world_node import SimrobotWorldNode

    # the shipped demo_matlab.yaml, its last robot's algorithm one that fails at step 5
    text = config_path("simrobot/demo_matlab.yaml").read_text().replace("algorithm: avoid_alg.m", f"algorithm: {ALG2}")
    head, _, last = text.rpartition(f"algorithm: {ALG2}")
    text = head + f"algorithm: {PROGRAMS / 'simrobot_fails.m'}" + last
    text = text.replace("map: demo_map.png", f"map: {config_path('simrobot/demo_map.png')}")
    (tmp_path / "demo_m.yaml").write_text(text)
    world = SimrobotWorldNode(parameter_overrides=[Parameter("world_file", value=str(tmp_path / "demo_m.yaml"))])
    executor.add_node(world)
    assert world.lockstep and world.spec.robots[2].algorithm == str(ALG2.resolve())
    assert spin_steps(executor, world, 60) == 60
    # the twin: r1-r3 by the Python alg2; r4 straight on for 4 steps, then stopped as its m-file failed
    twin = demo_world()
    for step in range(1, 61):
        twin.set_wheel_speeds(3, *(STRAIGHT if step < 5 else (0.0, 0.0)))
        run_python_twin(twin, [0, 1, 2], 1)
    assert np.array_equal(world.model.history.array(), twin.history.array())
    log = capfd.readouterr().err
    assert log.count("simrobot_fails.m failed at step 5") == 1 and "robot 'r4'" in log


def test_without_octave_a_world_with_an_algorithm_refuses_to_start_saying_what_to_install(monkeypatch, tmp_path):
    from simrobot_sim.matlab_alg import OctaveAlgorithms

    monkeypatch.delenv("OCTAVE_EXECUTABLE", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))  # no octave-cli, no octave
    with pytest.raises(InputError, match=r"run in GNU Octave: install it \(e\.g\. apt install octave\)"):
        OctaveAlgorithms(demo_world(), {0: ALG2})
    monkeypatch.setenv("OCTAVE_EXECUTABLE", str(tmp_path / "octave-9"))
    with pytest.raises(InputError, match=r"OCTAVE_EXECUTABLE=.*octave-9' is not an executable"):
        OctaveAlgorithms(demo_world(), {0: ALG2})


def test_the_shipped_matlab_demo_runs_avoid_alg_on_the_demo_robots():
    spec = load_world(config_path("simrobot/demo_matlab.yaml"))
    demo = load_world(config_path("simrobot/demo.yaml"))
    assert [r.algorithm for r in spec.robots] == [str(ALG2.resolve())] * 4
    assert [(r.position, r.heading, r.sensors) for r in spec.robots] == [
        (r.position, r.heading, r.sensors) for r in demo.robots
    ]


@needs_octave
def test_a_bad_setvel_and_a_syntax_error_are_reported_on_one_line_each_with_the_users_file(octave):
    reports: list[str] = []
    files = {0: PROGRAMS / "simrobot_bad_speed.m", 1: PROGRAMS / "simrobot_syntax.m"}
    tracks = run_mfiles(demo_world(), files, 3, octave, reports)
    assert len(reports) == 2 and all("\n" not in r and "failed at step 1" in r for r in reports)
    assert "setvel: expected [left right], two finite numbers, got [NaN 0.5] (simrobot_bad_speed line 3)" in reports[0]
    assert "parse error" in reports[1] and "simrobot_syntax.m" in reports[1]
    assert np.array_equal(tracks[0], tracks[-1])  # nobody moved


@needs_octave
def test_a_batch_sweep_can_name_an_algorithm_m_file_as_its_controller_and_matches_simrobot_avoid():
    from sim_tools.matlab.simrobot_batch import algorithm

    world = demo_world()
    control = algorithm(world, {"algorithm": str(ALG2), "threshold": 0.2}, 0)
    for _ in range(40):
        control(world, world.step_count * world.dt)
        world.step()
    control.algorithms.close()
    assert np.array_equal(world.history.array(), run_python_twin(demo_world(), list(range(4)), 40))
    with pytest.raises(InputError, match="parameter 'algorithm': the path of an algorithm m-file"):
        algorithm(demo_world(), {"algorithm": "alg2.py"}, 0)
