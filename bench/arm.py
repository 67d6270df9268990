"""Arm benchmark: arm_sim's numba kernels side by side with a plain-numpy implementation and
Robotics Toolbox for Python (if installed), STL loading, and the arm node's CPU use.

    .venv/bin/python bench/arm.py [--ik-targets 500] [--trimesh-ascii]

Goals: FK and Jacobian >= 5x rtb's C ``ETS.eval``/``ETS.jacob0`` per call from Python;
IK >= 99 % success at >= 2x rtb's C++ ``ik_LM``; a 756k-face STL in <= 0.05 s binary and
<= 3 s ASCII; the arm node publishing at 100 Hz with 7 links x several elements <= 10 % of a core.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np

from arm_sim.arm import Arm
from arm_sim.stl import load_stl, write_stl
from sim_runtime.paths import config_path

STL_FACES = 756_290  # the original's largest table row


def per_call(fn, args_list, repeat: int = 3) -> float:
    """Best-of-``repeat`` mean seconds per call of fn(*args) over args_list."""
    best = math.inf
    for _ in range(repeat):
        t = time.perf_counter()
        for args in args_list:
            fn(*args)
        best = min(best, (time.perf_counter() - t) / len(args_list))
    return best


def row(name: str, seconds: float, baseline: float | None = None, unit: str = "us") -> None:
    scale = {"us": 1e6, "ms": 1e3, "s": 1.0}[unit]
    ratio = f"   {baseline / seconds:7.1f}x" if baseline else ""
    print(f"  {name:<44s} {seconds * scale:10.3f} {unit}{ratio}")


# --- plain numpy baseline (same maths, no numba) ----------------------------------------------
def np_dh(theta, d, a, alpha):
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]])


def np_frames(arm: Arm, q):
    T = arm.base
    frames = [T]
    for i in range(arm.n):
        T = T @ np_dh(arm.chain.dh[i, 0] + q[i], arm.chain.dh[i, 1], arm.chain.dh[i, 2], arm.chain.dh[i, 3])
        frames.append(T)
    return frames


def np_fkine(arm: Arm, q):
    return np_frames(arm, q)[-1]


def np_jacob0(arm: Arm, q):
    frames = np_frames(arm, q)
    pe = frames[-1][:3, 3]
    J = np.zeros((6, arm.n))
    for i in range(arm.n):
        z, p = frames[i][:3, 2], frames[i][:3, 3]
        J[:3, i] = np.cross(z, pe - p)
        J[3:, i] = z
    return J


def np_rne(arm: Arm, q, qd, qdd):
    """World-frame Newton–Euler in plain numpy (standard DH, revolute joints)."""
    frames = np_frames(arm, q)
    w, wd, acc = np.zeros(3), np.zeros(3), -arm.gravity
    prev = frames[0][:3, 3]
    F, N, P, C, Z = [], [], [], [], []
    for i in range(arm.n):
        z, p = frames[i][:3, 2], frames[i][:3, 3]
        d = p - prev
        acc = acc + np.cross(wd, d) + np.cross(w, np.cross(w, d))
        wd = wd + z * qdd[i] + np.cross(w, z) * qd[i]
        w = w + z * qd[i]
        R = frames[i + 1][:3, :3]
        c = frames[i + 1][:3, 3] + R @ arm.dynamics.cog[i]
        dc = c - p
        F.append(arm.dynamics.mass[i] * (acc + np.cross(wd, dc) + np.cross(w, np.cross(w, dc))))
        Iw = R @ arm.dynamics.inertia[i] @ R.T
        N.append(Iw @ wd + np.cross(w, Iw @ w))
        P.append(p)
        C.append(c)
        Z.append(z)
        prev = p
    tau = np.zeros(arm.n)
    f, n, nxt = np.zeros(3), np.zeros(3), np.zeros(3)
    for i in range(arm.n - 1, -1, -1):
        n = n + np.cross(nxt - P[i], f) + np.cross(C[i] - P[i], F[i]) + N[i]
        f = f + F[i]
        nxt = P[i]
        tau[i] = n @ Z[i]
    return tau


def np_ikine(arm: Arm, T, q0, tol=1e-10, ilimit=30, slimit=100, rng=None):
    """The same LM algorithm in plain numpy (no extended searches)."""
    rng = rng or np.random.default_rng(0)
    q = np.clip(q0, arm.lower, arm.upper)
    for search in range(slimit):
        if search:
            q = rng.uniform(arm.lower, arm.upper)
        for _ in range(ilimit):
            Tq = np_fkine(arm, q)
            Re = T[:3, :3] @ Tq[:3, :3].T
            li = np.array([Re[2, 1] - Re[1, 2], Re[0, 2] - Re[2, 0], Re[1, 0] - Re[0, 1]])
            ln = np.linalg.norm(li)
            rot = li * math.atan2(ln, np.trace(Re) - 1) / ln if ln > 1e-9 else 0.5 * li
            e = np.concatenate([T[:3, 3] - Tq[:3, 3], rot])
            res = np.linalg.norm(e)
            if res < tol:
                return q, True
            J = np_jacob0(arm, q)
            A = J.T @ J + (0.5 * res * res + 1e-12) * np.eye(arm.n)
            q = np.clip(q + np.linalg.solve(A, J.T @ e), arm.lower, arm.upper)
    return q, False


def rtb_robot(arm: Arm):
    try:
        import roboticstoolbox as rtb
    except ImportError:
        return None
    links = [
        rtb.RevoluteDH(
            d=arm.chain.dh[i, 1],
            a=arm.chain.dh[i, 2],
            alpha=arm.chain.dh[i, 3],
            offset=arm.chain.dh[i, 0],
            qlim=arm.qlim[i],
            m=arm.dynamics.mass[i],
            r=arm.dynamics.cog[i],
            I=arm.dynamics.inertia[i],
            Jm=0,
            G=1,
        )
        for i in range(arm.n)
    ]
    robot = rtb.DHRobot(links, gravity=arm.gravity, name=arm.name)
    return robot


def bench_kinematics(arm: Arm, robot, n_targets: int) -> None:
    rng = np.random.default_rng(0)
    Q = rng.uniform(arm.lower, arm.upper, size=(500, arm.n))
    args = [(q,) for q in Q]
    ets = robot.ets() if robot is not None else None
    if robot is not None:
        assert np.allclose(robot.fkine(Q[0]).A, arm.fkine(Q[0]), atol=1e-12), "rtb model differs"
        assert np.allclose(ets.jacob0(Q[0]), arm.jacob0(Q[0]), atol=1e-12)
    arm.fkine(Q[0])
    arm.jacob0(Q[0])
    print(f"\n{arm.name}: forward kinematics, per call from Python (ratio = baseline / arm_sim)")
    ours = per_call(arm.fkine, args)
    if ets is not None:
        c_path = per_call(ets.eval, args)
        row("rtb ETS.eval (C)", c_path)
        row("rtb DHRobot.fkine (Python)", per_call(robot.fkine, args[:100]))
    row("plain numpy DH product", per_call(lambda q: np_fkine(arm, q), args[:200]))
    row("arm_sim Arm.fkine (numba)", ours, c_path if ets is not None else None)
    print(f"{arm.name}: geometric Jacobian (world frame), per call")
    ours = per_call(arm.jacob0, args)
    if ets is not None:
        c_path = per_call(ets.jacob0, args)
        row("rtb ETS.jacob0 (C)", c_path)
    row("plain numpy", per_call(lambda q: np_jacob0(arm, q), args[:200]))
    row("arm_sim Arm.jacob0 (numba)", ours, c_path if ets is not None else None)
    print(f"{arm.name}: batched FK, 10k configurations")
    Qb = rng.uniform(arm.lower, arm.upper, size=(10_000, arm.n))
    arm.fkine_batch(Qb[:2])
    row("arm_sim fkine_batch per configuration", per_call(arm.fkine_batch, [(Qb,)]) / len(Qb))

    print(f"{arm.name}: inverse kinematics, {n_targets} random reachable targets (tol: ours |e| < 1e-10)")
    Qt = rng.uniform(arm.lower, arm.upper, size=(n_targets, arm.n))
    targets = arm.fkine_batch(Qt)
    arm.ikine(targets[0])
    t = time.perf_counter()
    results = [arm.ikine(T) for T in targets]
    ours = (time.perf_counter() - t) / n_targets
    ok = np.array([r.success for r in results])
    err = max(np.abs(arm.fkine(r.q) - T).max() for r, T in zip(results, targets, strict=True) if r.success)
    if robot is not None:
        ets.ik_LM(targets[0])
        t = time.perf_counter()
        sols = [ets.ik_LM(T) for T in targets]
        theirs = (time.perf_counter() - t) / n_targets
        rok = np.array([s.success for s in sols])
        rerr = max(np.abs(ets.eval(s.q) - T).max() for s, T in zip(sols, targets, strict=True) if s.success)
        row(f"rtb ik_LM (C++): success {rok.mean():.1%}, max err {rerr:.1e}", theirs, unit="ms")
    sub = targets[:30]
    t = time.perf_counter()
    nok = [np_ikine(arm, T, arm.mid_range())[1] for T in sub]
    row(f"plain numpy LM (30 targets): success {np.mean(nok):.1%}", (time.perf_counter() - t) / len(sub), unit="ms")
    row(
        f"arm_sim ikine: success {ok.mean():.1%}, max err {err:.1e}",
        ours,
        theirs if robot is not None else None,
        unit="ms",
    )

    print(f"{arm.name}: inverse dynamics (RNE), per call")
    QD, QDD = rng.normal(size=Q.shape), rng.normal(size=Q.shape)
    dyn_args = list(zip(Q, QD, QDD, strict=True))
    arm.rne(*dyn_args[0])
    assert np.allclose(np_rne(arm, *dyn_args[0]), arm.rne(*dyn_args[0]), atol=1e-9)
    ours = per_call(arm.rne, dyn_args)
    if robot is not None:
        assert np.allclose(robot.rne(*dyn_args[0]), arm.rne(*dyn_args[0]), atol=1e-9), "rtb rne differs"
        row("rtb DHRobot.rne", per_call(robot.rne, dyn_args[:200]))
    numpy_rne = per_call(lambda *a: np_rne(arm, *a), dyn_args[:200])
    row("plain numpy Newton–Euler", numpy_rne)
    row("arm_sim Arm.rne (numba)", ours, numpy_rne)


def bench_stl(trimesh_ascii: bool) -> None:
    print(f"\nSTL loading, {STL_FACES} faces (ratio = trimesh process=False / arm_sim)")
    rng = np.random.default_rng(0)
    triangles = rng.uniform(-1, 1, size=(STL_FACES, 3, 3)).astype(np.float32)
    with tempfile.TemporaryDirectory() as tmp:
        binary, ascii_ = Path(tmp) / "big_bin.stl", Path(tmp) / "big_ascii.stl"
        write_stl(binary, triangles)
        write_stl(ascii_, triangles, ascii=True)
        print(f"  files: binary {binary.stat().st_size / 1e6:.1f} MB, ASCII {ascii_.stat().st_size / 1e6:.1f} MB")
        load_stl(binary)
        import trimesh

        def best(fn, repeat=3):
            times = []
            for _ in range(repeat):
                t = time.perf_counter()
                fn()
                times.append(time.perf_counter() - t)
            return min(times)

        row("plain read() of the binary file", best(binary.read_bytes), unit="s")
        tm_bin = best(lambda: trimesh.load(binary, process=False))
        row("trimesh.load binary, process=False", tm_bin, unit="s")
        row("arm_sim load_stl binary (goal <= 0.05 s)", best(lambda: load_stl(binary)), tm_bin, unit="s")
        row("plain read() of the ASCII file", best(ascii_.read_bytes), unit="s")
        tm_ascii = None
        if trimesh_ascii:
            tm_ascii = best(lambda: trimesh.load(ascii_, process=False), repeat=1)
            row("trimesh.load ASCII, process=False", tm_ascii, unit="s")
        ours = best(lambda: load_stl(ascii_))
        row("arm_sim load_stl ASCII (goal <= 3 s)", ours, tm_ascii, unit="s")
        assert np.allclose(load_stl(ascii_), triangles, rtol=1e-6, atol=1e-6)


def bench_node() -> None:
    import rclpy
    from rclpy.parameter import Parameter

    from arm_sim.arm_node import ArmNode

    print(
        "\narm node: CPU time per simulated second (physics 100 Hz, publishing at 100 Hz, arm moving, no subscribers)"
    )
    rclpy.init()
    try:
        for config in ("arm/csa7.yaml", "arm/irb120.yaml"):
            node = ArmNode(
                parameter_overrides=[
                    Parameter("robot_config_file", value=config),
                    Parameter("publish_rate", value=100.0),
                ]
            )
            node.step(100)
            arm = node.arm("")
            arm.motion.move_to(arm.arm.lower + 0.9 * (arm.arm.upper - arm.arm.lower), min_duration=30.0)
            steps = 2000
            cpu = time.process_time()
            node.step(steps)
            cpu = time.process_time() - cpu
            assert arm.motion.moving
            share = cpu / (steps * node.physics_dt)
            print(
                f"  {arm.arm.name}: {arm.arm.n} links, {len(arm.arm.elements)} mesh elements: "
                f"{share:.1%} of a core (goal <= 10 %)"
            )
            node.destroy_node()
    finally:
        rclpy.shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ik-targets", type=int, default=500)
    parser.add_argument("--trimesh-ascii", action="store_true", help="also time trimesh's ASCII loader (slow)")
    parser.add_argument("--skip", nargs="*", default=[], choices=["kinematics", "stl", "node"])
    args = parser.parse_args()
    if "kinematics" not in args.skip:
        for name in ("irb120", "csa7"):
            arm = Arm.from_file(config_path(f"arm/{name}.yaml"), load_meshes=False)
            robot = rtb_robot(arm)
            if robot is None and name == "irb120":
                print("roboticstoolbox-python not installed: rtb columns skipped")
            bench_kinematics(arm, robot, args.ik_targets)
    if "stl" not in args.skip:
        bench_stl(args.trimesh_ascii)
    if "node" not in args.skip:
        bench_node()


if __name__ == "__main__":
    main()
