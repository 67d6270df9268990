"""arm_sim model against an independent plain-numpy oracle written here.

FK multiplies the DH matrices one by one; the Jacobian is built from those frames and also
checked by finite differences; RNE is checked against the Lagrangian form
M(q) qdd + C(q, qd) qd + g(q) with M from link Jacobians and C from differentiating M.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from arm_sim.arm import Arm
from arm_sim.robot_config import load_robot_config
from sim_runtime.paths import config_path

IRB120 = config_path("arm/irb120.yaml")
CSA7 = config_path("arm/csa7.yaml")
SHIPPED_KINEMATICS = [Arm.from_file(path, load_meshes=False) for path in (IRB120, CSA7)]


# --- the oracle ------------------------------------------------------------------------------
def rot_z(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def rot_x(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def trans(x, y, z):
    T = np.eye(4)
    T[:3, 3] = [x, y, z]
    return T


def oracle_frames(cfg, q, base=None):
    """World frames 0..n by multiplying elementary transforms."""
    T = np.array(cfg.base if base is None else base, dtype=float)
    frames = [T]
    for i in range(cfg.dof):
        theta, d = cfg.theta[i], cfg.d[i]
        if cfg.joint_types[i] == "r":
            theta = theta + q[i]
        else:
            d = d + q[i]
        if cfg.modified_dh:
            A = rot_x(cfg.alpha[i]) @ trans(cfg.a[i], 0, 0) @ rot_z(theta) @ trans(0, 0, d)
        else:
            A = rot_z(theta) @ trans(0, 0, d) @ trans(cfg.a[i], 0, 0) @ rot_x(cfg.alpha[i])
        T = T @ A
        frames.append(T)
    return frames


def joint_axes(cfg, frames):
    """(axis point, axis direction) of every joint."""
    k = 1 if cfg.modified_dh else 0
    return [(frames[i + k][:3, 3], frames[i + k][:3, 2]) for i in range(cfg.dof)]


def oracle_jacobian_point(cfg, frames, point, upto):
    """6 x n Jacobian of a point attached to link ``upto`` (joints beyond it do not move it)."""
    J = np.zeros((6, cfg.dof))
    for i, (p, z) in enumerate(joint_axes(cfg, frames)[:upto]):
        if cfg.joint_types[i] == "r":
            J[:3, i] = np.cross(z, point - p)
            J[3:, i] = z
        else:
            J[:3, i] = z
    return J


def rotation_vector(R):
    angle = math.acos(max(-1.0, min(1.0, (np.trace(R) - 1) / 2)))
    if angle < 1e-12:
        return np.zeros(3)
    return angle / (2 * math.sin(angle)) * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])


def oracle_mass_matrix(cfg, q):
    frames = oracle_frames(cfg, q)
    dyn = cfg.dynamics
    M = np.zeros((cfg.dof, cfg.dof))
    for i in range(cfg.dof):
        R = frames[i + 1][:3, :3]
        c = frames[i + 1][:3, 3] + R @ dyn.cog[i]
        J = oracle_jacobian_point(cfg, frames, c, i + 1)
        Iw = R @ dyn.inertia[i] @ R.T
        M += dyn.mass[i] * J[:3].T @ J[:3] + J[3:].T @ Iw @ J[3:]
    return M


def oracle_gravity(cfg, q):
    frames = oracle_frames(cfg, q)
    dyn = cfg.dynamics
    g = np.zeros(cfg.dof)
    for i in range(cfg.dof):
        R = frames[i + 1][:3, :3]
        c = frames[i + 1][:3, 3] + R @ dyn.cog[i]
        J = oracle_jacobian_point(cfg, frames, c, i + 1)
        g -= dyn.mass[i] * J[:3].T @ dyn.gravity
    return g


def oracle_torque(cfg, q, qd, qdd, h=1e-6):
    """Lagrangian dynamics: M qdd + (dM/dt qd - 1/2 d/dq (qd^T M qd)) + g."""
    M = oracle_mass_matrix(cfg, q)
    Mdot = (oracle_mass_matrix(cfg, q + h * qd) - oracle_mass_matrix(cfg, q - h * qd)) / (2 * h)
    grad = np.zeros(cfg.dof)
    for k in range(cfg.dof):
        dq = np.zeros(cfg.dof)
        dq[k] = h
        grad[k] = (qd @ oracle_mass_matrix(cfg, q + dq) @ qd - qd @ oracle_mass_matrix(cfg, q - dq) @ qd) / (2 * h)
    return M @ qdd + Mdot @ qd - 0.5 * grad + oracle_gravity(cfg, q)


# --- test robots -----------------------------------------------------------------------------
def write_config(folder: Path, **overrides) -> Path:
    """A 4-DOF test arm with a prismatic joint and random dynamics, written as YAML."""
    rng = np.random.default_rng(7)
    A = rng.normal(size=(4, 3, 3))
    inertia = [(0.01 * (a @ a.T) + 0.001 * np.eye(3)).tolist() for a in A]
    raw = {
        "name": "test4",
        "dof": 4,
        "base": {"xyz": [0.1, -0.2, 0.3], "rpy": [0.1, 0.2, 0.3]},
        "joint_types": "rprr",
        "dh": {
            "theta": [0.1, 0.3, -0.2, 0.0],
            "d": [0.3, 0.2, 0.05, 0.1],
            "a": [0.05, 0.25, 0.2, 0.0],
            "alpha": ["-pi/2", "pi/2", 0.3, "pi/2"],
        },
        "limits": {"position": [[-3, 3], [0.0, 0.5], [-2, 2], [-3, 3]], "velocity": [1, 0.5, 1, 2]},
        "dynamics": {
            "mass": [2.0, 1.5, 1.0, 0.5],
            "cog": rng.uniform(-0.1, 0.1, size=(4, 3)).tolist(),
            "inertia": inertia,
        },
        "links": [{"link": 1, "elements": [{"mesh": "x.stl"}]}],
    }
    raw.update(overrides)
    path = folder / "test4.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.fixture(params=["standard", "modified"])
def arm4(request, tmp_path) -> Arm:
    path = write_config(tmp_path, modified_dh=request.param == "modified")
    return Arm.from_file(path, load_meshes=False)


@pytest.fixture(scope="module", params=["irb120", "csa7"])
def shipped(request) -> Arm:
    return Arm.from_file(config_path(f"arm/{request.param}.yaml"))


def random_q(arm: Arm, rng, m=None):
    return rng.uniform(arm.lower, arm.upper, size=(arm.n,) if m is None else (m, arm.n))


# --- kinematics ------------------------------------------------------------------------------
def test_irb120_home_pose_matches_the_seed_dh():
    arm = Arm.from_file(IRB120, load_meshes=False)
    T = arm.fkine(np.zeros(6))
    # wrist 0.30 ahead of the elbow at 0.29 + 0.27 + 0.07 m; flange 0.072 further along x
    np.testing.assert_allclose(T[:3, 3], [0.372, 0.0, 0.63], atol=1e-12)
    np.testing.assert_allclose(T[:3, 2], [1.0, 0.0, 0.0], atol=1e-12)  # tool z points forward


def test_fk_of_every_frame_matches_oracle(arm4):
    rng = np.random.default_rng(0)
    for q in random_q(arm4, rng, 20):
        frames = arm4.fkine_all(q)
        np.testing.assert_allclose(frames, np.array(oracle_frames(arm4.config, q)), atol=1e-12)
        np.testing.assert_allclose(arm4.fkine(q), frames[-1], atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=7, max_size=7))
def test_fk_matches_oracle_for_shipped_arms(fractions):
    for arm in SHIPPED_KINEMATICS:
        q = arm.mid_range() + 0.5 * np.array(fractions[: arm.n]) * (arm.upper - arm.lower)
        np.testing.assert_allclose(arm.fkine(q), oracle_frames(arm.config, q)[-1], atol=1e-12)


def test_batched_variants_equal_single_calls(shipped):
    rng = np.random.default_rng(1)
    Q = random_q(shipped, rng, 8)
    np.testing.assert_allclose(shipped.fkine_batch(Q), [shipped.fkine(q) for q in Q], atol=1e-14)
    np.testing.assert_allclose(shipped.jacob0_batch(Q), [shipped.jacob0(q) for q in Q], atol=1e-14)
    QD, QDD = rng.normal(size=Q.shape), rng.normal(size=Q.shape)
    np.testing.assert_allclose(
        shipped.rne_batch(Q, QD, QDD),
        [shipped.rne(q, qd, qdd) for q, qd, qdd in zip(Q, QD, QDD, strict=True)],
        atol=1e-12,
    )


def test_jacobian_matches_oracle_and_finite_differences(arm4):
    rng = np.random.default_rng(2)
    cfg = arm4.config
    h = 1e-7
    for q in random_q(arm4, rng, 10):
        J = arm4.jacob0(q)
        frames = oracle_frames(cfg, q)
        np.testing.assert_allclose(J, oracle_jacobian_point(cfg, frames, frames[-1][:3, 3], cfg.dof), atol=1e-12)
        T0 = arm4.fkine(q)
        for k in range(arm4.n):
            dq = np.zeros(arm4.n)
            dq[k] = h
            Tp, Tm = oracle_frames(cfg, q + dq)[-1], oracle_frames(cfg, q - dq)[-1]
            np.testing.assert_allclose(J[:3, k], (Tp[:3, 3] - Tm[:3, 3]) / (2 * h), atol=1e-7)
            omega = (rotation_vector(Tp[:3, :3] @ T0[:3, :3].T) - rotation_vector(Tm[:3, :3] @ T0[:3, :3].T)) / (2 * h)
            np.testing.assert_allclose(J[3:, k], omega, atol=1e-7)


def test_shipped_jacobians_match_finite_differences(shipped):
    rng = np.random.default_rng(3)
    q = random_q(shipped, rng)
    J = shipped.jacob0(q)
    h = 1e-7
    for k in range(shipped.n):
        dq = np.zeros(shipped.n)
        dq[k] = h
        dp = oracle_frames(shipped.config, q + dq)[-1][:3, 3] - oracle_frames(shipped.config, q - dq)[-1][:3, 3]
        np.testing.assert_allclose(J[:3, k], dp / (2 * h), atol=1e-7)


# --- inverse kinematics ----------------------------------------------------------------------
def test_ik_round_trips_on_random_reachable_targets(shipped):
    rng = np.random.default_rng(4)
    Q = random_q(shipped, rng, 300)
    targets = np.array([oracle_frames(shipped.config, q)[-1] for q in Q])
    Qs, ok, _residual = shipped.ikine_batch(targets)
    assert ok.mean() >= 0.99
    for q, target in zip(Qs[ok], targets[ok], strict=True):
        reached = oracle_frames(shipped.config, q)[-1]
        np.testing.assert_allclose(reached, target, atol=1e-8)  # checked by the oracle, not the kernel
        assert shipped.within_limits(q)


def test_ik_with_initial_guess_near_solution_converges_in_one_search(shipped):
    rng = np.random.default_rng(5)
    q = random_q(shipped, rng)
    result = shipped.ikine(shipped.fkine(q), q0=q + 0.01)
    assert result.success and result.searches == 1
    np.testing.assert_allclose(shipped.fkine(result.q), shipped.fkine(q), atol=1e-8)


def test_ik_reports_failure_for_unreachable_pose():
    arm = Arm.from_file(IRB120, load_meshes=False)
    target = np.eye(4)
    target[:3, 3] = [2.0, 0.0, 0.5]  # the IRB120 reaches 0.58 m
    result = arm.ikine(target, slimit=10)
    assert not result.success
    assert result.residual > 1.0


def test_batched_ik_seeds_the_restarts_of_target_k_with_seed_plus_k():
    arm = Arm.from_file(IRB120, load_meshes=False)
    rng = np.random.default_rng(12)
    targets = arm.fkine_batch(random_q(arm, rng, 3))
    targets[2, :3, 3] = [2.0, 0.0, 0.5]  # out of reach: every restart runs, its seed shows in q
    Q, ok, residual = arm.ikine_batch(targets, slimit=4, seed=7)
    for k, target in enumerate(targets):
        single = arm.ikine(target, slimit=4, seed=7 + k)
        assert np.array_equal(Q[k], single.q)
        assert (ok[k], residual[k]) == (single.success, single.residual)
    assert not ok[2]


# --- dynamics --------------------------------------------------------------------------------
def test_rne_matches_lagrangian_oracle(arm4):
    rng = np.random.default_rng(6)
    for _ in range(5):
        q = random_q(arm4, rng)
        qd, qdd = rng.normal(size=arm4.n), rng.normal(size=arm4.n)
        expected = oracle_torque(arm4.config, q, qd, qdd)
        np.testing.assert_allclose(arm4.rne(q, qd, qdd), expected, atol=1e-6, rtol=1e-6)


def test_rne_of_shipped_arms_matches_lagrangian_oracle(shipped):
    rng = np.random.default_rng(8)
    q = random_q(shipped, rng)
    qd, qdd = rng.normal(size=shipped.n), rng.normal(size=shipped.n)
    np.testing.assert_allclose(shipped.rne(q, qd, qdd), oracle_torque(shipped.config, q, qd, qdd), atol=1e-6, rtol=1e-6)
    np.testing.assert_allclose(shipped.inertia(q), oracle_mass_matrix(shipped.config, q), atol=1e-10)


def test_gravload_holds_the_arm(arm4):
    rng = np.random.default_rng(9)
    q = random_q(arm4, rng)
    np.testing.assert_allclose(arm4.gravload(q), oracle_gravity(arm4.config, q), atol=1e-10)


def test_rne_under_another_gravity_leaves_the_arms_own_gravity_alone():
    arm = Arm.from_file(IRB120, load_meshes=False)
    q = random_q(arm, np.random.default_rng(13))
    held = arm.gravload(q)
    zero = np.zeros(arm.n)
    assert np.array_equal(arm.rne(q, zero, zero, gravity=[0.0, 0.0, 0.0]), zero)  # at rest, weightless
    np.testing.assert_allclose(arm.rne(q, zero, zero, gravity=2.0 * arm.gravity), 2.0 * held, atol=1e-12)
    assert np.array_equal(arm.gravity, [0.0, 0.0, -9.81])
    assert np.array_equal(arm.gravload(q), held)


def test_irb120_gravity_torques_are_plausible():
    arm = Arm.from_file(IRB120, load_meshes=False)
    g = arm.gravload(np.zeros(6))
    assert g[0] == pytest.approx(0.0, abs=1e-12)  # axis 1 is vertical
    assert -20.0 < g[1] < -1.0  # the forearm held out horizontally loads the shoulder


# --- config and meshes -----------------------------------------------------------------------
def test_shipped_configs_load_with_their_meshes():
    irb = load_robot_config(IRB120)
    assert irb.name == "IRB120" and irb.dof == 6
    np.testing.assert_allclose(np.degrees(irb.position_limits[2]), [-110, 70])
    np.testing.assert_allclose(np.degrees(irb.velocity_limits), [250, 250, 250, 320, 320, 420])
    assert irb.links[6][0].color == (0.1, 0.1, 0.1, 1.0)
    csa = Arm.from_file(CSA7)
    assert csa.n == 7
    assert len(csa.elements) >= 20
    assert all(len(link) >= 2 for link in csa.config.links)
    assert all(e.triangles.shape[1:] == (3, 3) and len(e.triangles) >= 12 for e in csa.elements)


def test_element_poses_follow_their_links(shipped):
    q = shipped.mid_range()
    frames = shipped.fkine_all(q)
    poses = shipped.element_poses(q)
    for element, pose in zip(shipped.elements, poses, strict=True):
        np.testing.assert_allclose(pose, frames[element.link])
