"""The learning environments' speed (issue 21): env steps per second against the bare models,
on one core and on two, and against IR-SIM's environment step.

    .venv/bin/python bench/envs.py            # ~2 min; --quick: fewer steps, ~40 s

1. **Wrapper cost** (one core, CPU time of this process; env and bare take turns in short chunks,
   the cost is the median of the pairs' time ratios: this machine's speed drifts by tens of per
   cent within a minute, and a pair of chunks sees one speed):
   each env's step against the bare model doing the same work through its own API —
   ``CreateNav-v0`` (24 LIDAR beams, bumpers, goal) and ``CreateCover-v0`` (24 beams, bumpers):
   the command, 10 physics steps of ``CreateModel``, the same sensor reads and one collision check
   (``clearance``); ``ArmReach-v0`` (IRB120): the env's own kernels (the joints moved within their
   limits, the observation and errors) and ``Arm.fkine``, without the env's step around them
   (``Arm.fkine`` alone is printed too); the SIMROBOT ``ParallelEnv`` (demo world, 4 agents):
   ``set_wheel_speeds`` per robot, ``SimrobotWorld.step`` and every sensor read; the same with
   1,000 agents (the empty map of item 2).
2. **One core and two** (wall time, best of several, taking turns): a Gymnasium env on two cores is two processes,
   each stepping its own env (a user training two runs); the vector Create env
   (``gymnasium.make_vec("robot_sims/CreateNav-v0", num_envs=32, workers=1 or 2)``, random actions,
   episodes reset as they end) against 32 bare models in one process; the SIMROBOT env with 1,000
   agents (an empty 21 m x 21 m map, one 30-ray ultrasonic sensor each) with the world's
   ``threads`` 1 and 2. Goals: vector Create >= 15,000 env steps/s with LIDAR on 2 cores;
   SIMROBOT 1,000 agents >= 40 steps/s on 2 cores.
3. **IR-SIM** (``pip install ir-sim``; the table is skipped without it), one core, CPU time:
   N = 1, 10, 100 differential-drive robots with a 30-ray 180° 2 m LIDAR each on an empty
   10 m x 10 m world with one box, every robot's action set and scan read each step — IR-SIM's
   ``env.step`` against the SIMROBOT ``ParallelEnv`` on the same scene (1 cm cells, a 30-ray laser
   of the same fan per robot, ``threads: 1``).
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from create_sim import spec
from create_sim.mapfile import load_map
from create_sim.model import CreateModel
from sim_runtime.paths import config_path
from sim_tools.rl.arm_reach import ArmReachEnv, _moved, _observation
from sim_tools.rl.create_cover import CreateCoverEnv
from sim_tools.rl.create_nav import CreateNavEnv
from sim_tools.rl.simrobot_parallel import SimrobotParallelEnv
from sim_tools.rl.vector_create import CreateNavVectorEnv, vector_create_nav

START = (-1.5, -1.0, 0.0)
CIRCLE = np.array([0.05, 0.3], dtype=np.float32)  # a slow circle on the example map: no bump, no goal
VECTOR_ENVS = 32
GOAL_VECTOR = 15_000.0
GOAL_SIMROBOT = 40.0
GOAL_COST = 0.15
GOAL_FRAME_MS = 20.0
#: The LIDAR of the IR-SIM comparison, on both sides: rays, field of view (rad), range (m).
SCAN_RAYS, SCAN_FOV, SCAN_RANGE = 30, math.pi, 2.0

Run = Callable[[int], None]  # steps → None


def load() -> str:
    return "load average {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(), os.cpu_count())


def rate(run: Run, steps: int, clock: Callable[[], float] = time.process_time) -> float:
    """Steps per second, the best of 3 runs (after a warm-up)."""
    return rates([run], steps, clock)[0]


def rates(runs: list[Run], steps: int, clock: Callable[[], float] = time.process_time, repeats: int = 3) -> list[float]:
    """Each run's steps per second, the best of ``repeats``, the runs taking turns (after a warm-up
    each): a load that comes and goes falls on all of them alike."""
    for run in runs:
        run(max(1, steps // 10))
    best = [math.inf] * len(runs)
    for _ in range(repeats):
        for k, run in enumerate(runs):
            t = clock()
            run(steps)
            best[k] = min(best[k], clock() - t)
    return [steps / b for b in best]


# ------------------------------------------------------------------------------------ 1. wrapper cost
def create_pair(env_class: type[CreateNavEnv]) -> tuple[Run, Run]:
    """(env run, bare model run) of a Create env at its default sensors, on a slow circle."""
    extra = {"goal": (3.0, 1.0)} if env_class is CreateNavEnv else {}
    env = env_class(start=START, max_steps=10**9, **extra)
    env.reset(seed=0)
    model = CreateModel(load_map(config_path("create/example.map")), pose=START)
    index, substeps, reads = env.lidar_index, env.substeps, env.sensors
    v, w = float(CIRCLE[0]), float(CIRCLE[1])

    def bare(steps: int) -> None:
        for _ in range(steps):
            model.set_velocity(v, w)
            for _ in range(substeps):
                model.step(1.0 / spec.PHYSICS_RATE)
            model.lidar(index), model.bumps()
            model.clearance()  # the collision check: one a step away from walls, as the env's
            if "goal" in reads:
                model.odometry_pose  # noqa: B018 (a read, as the env's)

    def wrapped(steps: int) -> None:
        for _ in range(steps):
            env.step(CIRCLE)

    return wrapped, bare


def arm_pair() -> tuple[Run, Run, Run]:
    """(env run, the same work without the env, ``Arm.fkine`` alone) of ArmReach-v0."""
    env = ArmReachEnv("irb120", max_steps=10**9)
    env.reset(seed=0)
    arm, target = env.arm, env.target
    qd = np.full(arm.n, 0.01, dtype=np.float32)
    limit, lower, upper = arm.velocity_limits, arm.lower, arm.upper

    def wrapped(steps: int) -> None:
        for _ in range(steps):
            env.step(qd)

    def bare(steps: int) -> None:
        # the env's own numerical work, the same calls (its kernels: joints moved within their
        # limits, the observation and errors), without Gymnasium's step around them: reward,
        # flags, info. (Before, numpy's clip and pose_error here cost more than the env's
        # kernels, and the env looked cheaper than its own work: "-42 %".)
        q = env.q
        action = np.asarray(qd, dtype=float)
        for _ in range(steps):
            q = _moved(q, action, env.dt, limit, lower, upper)
            _observation(q, target, arm.fkine(q))

    def fkine(steps: int) -> None:
        for _ in range(steps):
            arm.fkine(env.q)

    return wrapped, bare, fkine


def simrobot_pair(world_file: str | Path = "simrobot/demo.yaml") -> tuple[Run, Run]:
    """(env run, bare world run) of the SIMROBOT ParallelEnv: every agent at slow wheel speeds."""
    env = SimrobotParallelEnv(world_file, max_steps=10**9)
    env.reset(seed=0)
    world = env._fresh_template()
    speeds = np.array([0.02, 0.03], dtype=np.float32)  # slow: nobody crashes during the runs
    actions = dict.fromkeys(env.possible_agents, speeds)

    def wrapped(steps: int) -> None:
        for _ in range(steps):
            env.step(actions)

    def bare(steps: int) -> None:
        for _ in range(steps):
            for i in range(len(world.names)):
                world.set_wheel_speeds(i, 0.02, 0.03)
            world.step()
            for k, sensor in enumerate(world.sensors):
                world.nearest(k) if sensor.kind == "ultrasonic" else world.ranges(k)

    return wrapped, bare


def paired_cost(wrapped: Run, bare: Run, steps: int, chunk: int) -> tuple[float, float, float]:
    """(env steps/s, bare steps/s, cost) from short chunks of ``chunk`` steps, env and bare taking
    turns: the cost is the median over the pairs of (env time / bare time) - 1 (each pair ran at
    one moment of the machine's speed, which drifts by tens of per cent here), the rates the
    medians over the chunks."""
    wrapped(chunk), bare(chunk)
    env_times, bare_times = [], []
    for _ in range(max(1, steps // chunk)):
        for run, times in ((wrapped, env_times), (bare, bare_times)):
            t = time.process_time()
            run(chunk)
            times.append(time.process_time() - t)
    env_s, bare_s = np.array(env_times), np.array(bare_times)
    cost = float(np.median(env_s / bare_s)) - 1.0
    return chunk / float(np.median(env_s)), chunk / float(np.median(bare_s)), cost


def wrapper_table(steps: int) -> None:
    print("1. wrapper cost, one core (CPU time; env and bare take turns in chunks of 50 steps, the cost the")
    print(f"   median of the pairs' time ratios, {3 * steps:,} steps each); {load()}")
    print(f"{'env':<44}{'env steps/s':>13}{'bare model':>13}{'cost':>8}   goal <= {GOAL_COST:.0%}")
    nav, cover, (arm, arm_bare, fkine), sim = (
        create_pair(CreateNavEnv),
        create_pair(CreateCoverEnv),
        arm_pair(),
        simrobot_pair(),
    )
    rows = [
        ("CreateNav-v0 (24 beams, bumpers, goal)", *nav, 1),
        ("CreateCover-v0 (24 beams, bumpers)", *cover, 1),
        ("ArmReach-v0 (IRB120)", arm, arm_bare, 10),
        ("SIMROBOT ParallelEnv (demo, 4 agents)", *sim, 1),
    ]
    for name, wrapped, bare, scale in rows:
        env_rate, bare_rate, cost = paired_cost(wrapped, bare, 3 * steps * scale, 50 * scale)
        met = "met" if cost <= GOAL_COST else "NOT met"
        print(f"{name:<44}{env_rate:>13,.0f}{bare_rate:>13,.0f}{cost:>+8.0%}   {met}")
    print(f"{'  (ArmReach-v0: Arm.fkine alone)':<44}{'':>13}{rate(fkine, steps * 10):>13,.0f}")
    with tempfile.TemporaryDirectory() as folder:  # the same at scale: chunks of 2 steps
        many = simrobot_pair(many_robots_world(Path(folder), 1000, 1))
        env_rate, bare_rate, cost = paired_cost(*many, max(20, steps // 25), 2)
    met = "met" if cost <= GOAL_COST else "NOT met"
    print(
        f"{'SIMROBOT ParallelEnv (1,000 agents, empty)':<44}{env_rate:>13,.1f}{bare_rate:>13,.1f}{cost:>+8.0%}   {met}"
    )


# ------------------------------------------------------------------------------------ 2. cores
def _in_processes(make: Callable[[], Run], steps: int, processes: int) -> float:
    """Env steps/s of ``processes`` processes stepping their own env at once (wall time, summed)."""
    context = multiprocessing.get_context("fork")
    queue = context.Queue()

    def one() -> None:
        queue.put(rate(make(), steps, time.perf_counter))

    workers = [context.Process(target=one) for _ in range(processes)]
    for worker in workers:
        worker.start()
    total = sum(queue.get() for _ in workers)
    for worker in workers:
        worker.join()
    return total


def cpu_seconds(pid: int) -> float:
    """CPU time (user + system) of process ``pid`` so far (Linux)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _spin(steps: int) -> None:
    # the machine's own speed-up from a second process, nothing of ours in it
    for _ in range(steps):
        sum(range(2000))


def vector_run(
    workers: int, random: bool = True
) -> tuple[Run, Callable[[], int], Callable[[], float], CreateNavVectorEnv]:
    """(run, close → episodes ended, CPU clock of every process stepping it, the env) of the vector
    Create env: random actions (episodes end and reset), or every sub-env on the slow circle (none
    ends: the bare models' work). With 2 workers it measures itself on its first 45 steps and may
    fall back to this process (``envs.fell_back``)."""
    envs = vector_create_nav(VECTOR_ENVS, workers=workers, sensors=("lidar", "bump", "goal"), max_steps=10**9)
    if random:
        envs.reset(seed=0)
        low, high = envs.single_action_space.low, envs.single_action_space.high
        actions = np.random.default_rng(0).uniform(low, high, (64, VECTOR_ENVS, 2)).astype(np.float32)
    else:
        envs.reset(seed=0, options={"start": START, "goal": (3.0, 1.0)})
        actions = np.tile(CIRCLE, (64, VECTOR_ENVS, 1))
    ended = [0]

    def run(steps: int) -> None:
        for k in range(steps):
            _obs, _rewards, terms, truncs, _infos = envs.step(actions[k % 64])
            ended[0] += int(terms.sum() + truncs.sum())

    def close() -> int:
        envs.close()
        return ended[0]

    def cpu_clock() -> float:
        return time.process_time() + sum(cpu_seconds(process.pid) for process in envs._processes)

    return run, close, cpu_clock, envs


def bare_models_run() -> Run:
    """VECTOR_ENVS Create models doing the vector env's model work, one after the other."""
    floor = load_map(config_path("create/example.map"))
    models = [CreateModel(floor, pose=START) for _ in range(VECTOR_ENVS)]
    index = np.linspace(0, CreateModel.LIDAR_BEAMS - 1, 24).round().astype(int)

    def run(steps: int) -> None:
        for _ in range(steps):
            for model in models:
                model.set_velocity(0.05, 0.3)
                for _ in range(10):
                    model.step(1.0 / spec.PHYSICS_RATE)
                model.lidar(index), model.bumps(), model.odometry_pose

    return run


def many_robots_world(folder: Path, n: int, threads: int) -> Path:
    """A world file of ``n`` robots (one 30-ray ultrasonic each) on an empty 21 m x 21 m map."""
    from PIL import Image

    side = 2100
    picture = np.full((side, side), 255, dtype=np.uint8)
    picture[[0, -1], :] = picture[:, [0, -1]] = 0
    Image.fromarray(picture).save(folder / "empty.png")
    per_row = math.ceil(math.sqrt(n))
    lines = [f"map: empty.png\nresolution: 0.01\ndt: 0.1\nthreads: {threads}\nrobots:"]
    sensor = "{name: us, type: ultrasonic, position: [0.05, 0], beamwidth: 60, range: 0.5, rays: 30}"
    for i in range(n):
        x, y = 0.5 + 0.6 * (i % per_row), 0.5 + 0.6 * (i // per_row)
        lines.append(f"  - {{name: r{i}, position: [{x:.2f}, {y:.2f}], heading: 0, sensors: [{sensor}]}}")
    path = folder / f"many_{n}_{threads}.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def row(name: str, one: float, two: float, goal: str = "", digits: int = 0) -> None:
    print(f"{name:<52}{one:>10,.{digits}f}{two:>10,.{digits}f}{two / one:>7.2f}  {goal}".rstrip())


def processes_row(name: str, make: Callable[[], Run], steps: int) -> None:
    """One process, then two at once, each stepping its own (taking turns twice: the same load)."""
    one = two = 0.0
    for _ in range(2):
        one = max(one, _in_processes(make, steps, 1))
        two = max(two, _in_processes(make, steps, 2))
    row(name, one, two)


def vector_rows(steps: int) -> None:
    """The vector Create env on 1 and 2 workers (the goal), and its cost over the bare models."""
    (one_run, one_close, _, _), (two_run, two_close, two_cpu, two) = vector_run(1), vector_run(2)
    vector_steps = steps // VECTOR_ENVS * 2
    both = [VECTOR_ENVS * r for r in rates([one_run, two_run], vector_steps, time.perf_counter, 6)]
    per_cpu_second = VECTOR_ENVS * rate(two_run, vector_steps, two_cpu)
    ended = one_close() + two_close()
    met = "met" if both[1] >= GOAL_VECTOR else "NOT met"
    row(f"vector CreateNav-v0 x {VECTOR_ENVS}, random actions, LIDAR", *both, f">= {GOAL_VECTOR:,.0f}: {met}")
    print(f"  ({ended} episodes ended and were reset during these runs)")
    if two.fell_back:
        print(f"  the 2-worker env fell back to one process: {two.fell_back}")
    print(
        f"  2 workers: {1e6 / per_cpu_second:.0f} us of CPU per env step (both processes): two idle cores"
        f" would make ~{2 * per_cpu_second:,.0f} env steps/s (a projection, not a measurement)"
    )
    run, close, _, _ = vector_run(1, random=False)
    circling, bare, cost = paired_cost(run, bare_models_run(), vector_steps, 2)
    close()
    print(
        f"  the same on the slow circle (no resets), one process, CPU time in paired chunks: "
        f"{VECTOR_ENVS * circling:,.0f} env steps/s; {VECTOR_ENVS} bare models doing that work "
        f"{VECTOR_ENVS * bare:,.0f}/s: cost {cost:+.0%}"
    )


def cores_table(steps: int, folder: Path) -> None:
    print(f"\n2. one core and two (wall time, best of several, taking turns); {load()}")
    print(f"{'env':<52}{'1 core':>10}{'2 cores':>10}{'ratio':>7}  goal (2 cores)")
    processes_row("the machine now: a pure-Python loop (2.00 if idle)", lambda: _spin, steps)
    processes_row("CreateNav-v0, 1 env per process", lambda: create_pair(CreateNavEnv)[0], steps)
    processes_row("ArmReach-v0, 1 env per process", lambda: arm_pair()[0], steps * 10)
    vector_rows(steps)
    worlds = [simrobot_pair(many_robots_world(folder, 1000, threads))[0] for threads in (1, 2)]
    sim = rates(worlds, 5, time.perf_counter)
    met = "met" if sim[1] >= GOAL_SIMROBOT else "NOT met"
    row("SIMROBOT ParallelEnv, 1,000 agents (threads 1, 2)", *sim, f">= {GOAL_SIMROBOT:.0f}: {met}", 1)


# ------------------------------------------------------------------------------------ 3. IR-SIM
def scene_robots(n: int, seed: int = 1) -> list[tuple[float, float, float]]:
    """``n`` poses on the 10 m x 10 m scene, clear of the box and of each other."""
    rng = np.random.default_rng(seed)
    poses: list[tuple[float, float, float]] = []
    while len(poses) < n:
        x, y = rng.uniform(0.5, 9.5, 2)
        if (2.2 < x < 3.8 and 2.5 < y < 3.5) or any(math.hypot(x - a, y - b) < 0.4 for a, b, _ in poses):
            continue
        poses.append((float(x), float(y), float(rng.uniform(-math.pi, math.pi))))
    return poses


def irsim_run(folder: Path, n: int) -> Run:
    import irsim

    robots = "\n".join(
        f"  - kinematics: {{name: diff}}\n    shape: {{name: circle, radius: 0.1}}\n    state: [{x}, {y}, {h}]\n"
        f"    sensors:\n      - {{name: lidar2d, range_min: 0, range_max: {SCAN_RANGE}, angle_range: {SCAN_FOV},"
        f" number: {SCAN_RAYS}}}"
        for x, y, h in scene_robots(n)
    )
    world = folder / f"irsim_{n}.yaml"
    world.write_text(
        "world: {height: 10, width: 10, step_time: 0.1, sample_time: 0.1, offset: [0, 0], collision_mode: stop}\n"
        f"robot:\n{robots}\n"
        "obstacle:\n  - {shape: {name: rectangle, length: 1.0, width: 0.5}, state: [3, 3, 0]}\n"
    )
    env = irsim.make(str(world), display=False, headless=True, log_level="WARNING", seed=0)
    actions = [np.array([[0.05], [0.1]]) for _ in range(n)]

    def run(steps: int) -> None:
        for _ in range(steps):
            env.step(actions, action_id=0)
            [robot.get_lidar_scan()["ranges"] for robot in env.robot_list]

    return run


def simrobot_scene_file(folder: Path, n: int) -> Path:
    """The IR-SIM scene as a SIMROBOT world: 1 cm cells, the box, a laser of the same fan."""
    from PIL import Image

    picture = np.full((1000, 1000), 255, dtype=np.uint8)  # rows from the top: y = 10 - row / 100
    picture[1000 - 325 : 1000 - 275, 250:350] = 0  # the 1 m x 0.5 m box centred on (3, 3)
    Image.fromarray(picture).save(folder / "scene.png")
    sensor = (
        f"{{name: scan, type: laser, position: [0, 0], beamwidth: {math.degrees(SCAN_FOV):g},"
        f" range: {SCAN_RANGE}, rays: {SCAN_RAYS}}}"
    )
    lines = ["map: scene.png\nresolution: 0.01\ndt: 0.1\nthreads: 1\nrobots:"]
    for i, (x, y, h) in enumerate(scene_robots(n)):
        lines.append(f"  - {{name: r{i}, position: [{x}, {y}], heading: {math.degrees(h)}, sensors: [{sensor}]}}")
    path = folder / f"scene_{n}.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def irsim_table(steps: int, folder: Path) -> None:
    try:
        import irsim  # noqa: F401
    except ImportError:
        print("\n3. IR-SIM: not installed (pip install ir-sim): skipped")
        return
    print(f"\n3. against IR-SIM's environment step, one core (CPU time, best of 3); {load()}")
    print(f"{'robots':>7}{'IR-SIM steps/s':>16}{'SIMROBOT env':>14}{'ratio':>8}")
    for n in (1, 10, 100):
        theirs = rate(irsim_run(folder, n), max(3, steps // (20 * n)))
        ours = rate(simrobot_pair(simrobot_scene_file(folder, n))[0], max(10, steps // (2 * n)))
        print(f"{n:>7}{theirs:>16,.1f}{ours:>14,.1f}{ours / theirs:>7.0f}x")


def frames_table(frames: int) -> None:
    """4. One ``render()`` frame (rgb_array, wall time, median of ``frames``) of each env with
    rendering, mid-episode (a track, every sensor's rays)."""
    print(f"\n4. a rendered frame (render_mode='rgb_array', wall time, median of {frames}); {load()}")
    print(f"{'env':<52}{'ms per frame':>14}   goal <= {GOAL_FRAME_MS:.0f} ms")
    every = ("lidar", "sonar", "bump", "goal")
    nav = CreateNavEnv(render_mode="rgb_array", sensors=every, start=START, goal=(1.0, 0.5))
    cover = CreateCoverEnv(render_mode="rgb_array", start=START)
    sim = SimrobotParallelEnv(render_mode="rgb_array", max_steps=10**9)
    for env in (nav, cover):
        env.reset(seed=0)
        for _ in range(100):
            env.step(CIRCLE)
    sim.reset(seed=0)
    for _ in range(100):
        sim.step(dict.fromkeys(sim.agents, np.array([0.5, 0.4], dtype=np.float32)))
    rows = [
        ("CreateNav-v0 (24 beams, 4 sonar, bumpers, goal)", nav.render),
        ("CreateCover-v0 (24 beams, bumpers)", cover.render),
        ("SIMROBOT ParallelEnv (demo, 4 robots)", sim.render),
    ]
    for name, render in rows:
        render()
        times = []
        for _ in range(frames):
            t = time.perf_counter()
            render()
            times.append(time.perf_counter() - t)
        ms = 1000.0 * float(np.median(times))
        print(f"{name:<52}{ms:>14.1f}   {'met' if ms <= GOAL_FRAME_MS else 'NOT met'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="fewer steps (about a minute)")
    steps = 1000 if parser.parse_args().quick else 5000
    wrapper_table(steps)
    frames_table(20 if parser.parse_args().quick else 100)
    with tempfile.TemporaryDirectory() as folder:
        cores_table(steps, Path(folder))
        irsim_table(steps, Path(folder))
    print(f"\n{load()}")


if __name__ == "__main__":
    main()
