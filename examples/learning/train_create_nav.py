"""Learn a Create controller: CMA-ES over a small numpy policy on ``robot_sims/CreateNav-v0``.

The task: drive from a random start to a random goal region on ``config/create/example.map``
without touching a wall (from any side: reversing into one is a collision too), seeing what a real
robot sees (LIDAR over the front 240°, bumpers, the goal from odometry).
The learner is CMA-ES (the ``cma`` package, in the ``rl`` extra) over every weight of a
:class:`~sim_tools.rl.policy.MlpPolicy`: no gradients, no GPU. Each candidate drives a few
episodes (the same seeds for every candidate of a generation) in worker processes; its fitness
is the mean return.

    python examples/learning/train_create_nav.py --minutes 15 --out examples/learning/create_nav_policy.npz

The policy file then runs anywhere a policy file does: ``policy.act(obs)`` in the env,
``robot_sims policy_controller`` against the ROS world, ``robot_sims batch``.
:func:`evaluate` compares it with a model-level copy of ``create_bump_turn`` and random actions.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, cast

import cma
import numpy as np
from gymnasium import spaces

from sim_tools.rl.create_nav import CreateNavEnv
from sim_tools.rl.policy import MlpPolicy, load_policy
from sim_tools.rl.vector_create import worker_signals

ENV_ID = "robot_sims/CreateNav-v0"
#: The env's options, saved in the policy file (the ROS policy controller rebuilds the observation
#: from them). Map and noise: the env's defaults (config/create/example.map, noise-free).
ENV_KWARGS: dict[str, Any] = {
    "sensors": ["lidar", "bump", "goal"],
    "lidar_beams": 12,
    "control_period_s": 0.1,
    "goal_radius_m": 0.3,
    "max_steps": 600,  # 60 s
}
HIDDEN = (8,)
#: Evaluation seeds start here; training draws its episode seeds below it.
EVAL_SEED0 = 1_000_000


class Controller(Protocol):
    """Anything that drives an episode: ``reset`` at its start, then ``act`` every step."""

    def reset(self, seed: int) -> None: ...

    def act(self, obs: np.ndarray) -> np.ndarray: ...


@dataclass
class Episode:
    """One episode's outcome (``time_s``: to the goal, or the whole episode): ``collisions`` and
    ``bumps`` count events (a wall came to touch the body / a bumper became pressed); ``steps``,
    ``backward_steps`` (commanded v < 0) and ``contact_steps`` (a wall touching the body) count
    env steps, ``mean_v`` is the commanded forward speed's mean (m/s)."""

    ret: float
    success: bool
    time_s: float
    bumps: int
    collisions: int = 0
    steps: int = 0
    backward_steps: int = 0
    contact_steps: int = 0
    mean_v: float = 0.0


# ------------------------------------------------------------------------------ controllers
class PolicyController:
    """A policy file's network as a :class:`Controller` (it has no state)."""

    def __init__(self, policy: MlpPolicy) -> None:
        self.policy = policy

    def reset(self, seed: int) -> None:
        pass

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.policy.act(obs)


class RandomController:
    """Uniform random actions in the env's action bounds (seeded per episode)."""

    def __init__(self, env: CreateNavEnv) -> None:
        box = cast(spaces.Box, env.action_space)
        self.low, self.high = box.low, box.high
        self.rng = np.random.default_rng(0)

    def reset(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.rng.uniform(self.low, self.high).astype(np.float32)


class BumpTurnController:
    """A model-level copy of ``create_bump_turn``'s logic (create_sim/bump_turn.py), one decision
    per env step: forward; on a bump back up, turn away by a random angle, forward again."""

    def __init__(self, env: CreateNavEnv) -> None:
        from create_sim import bump_turn

        self.bt = bump_turn
        self.dt = env.substeps / 100.0  # the env's control period (100 Hz physics)
        lidar = len(env.lidar_index) if "lidar" in env.sensors else 0
        self.bump_at = lidar + (4 if "sonar" in env.sensors else 0)
        self.reset(0)

    def reset(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.state, self.left, self.hit, self.rate = "forward", 0.0, set[str](), 0.0

    def act(self, obs: np.ndarray) -> np.ndarray:
        left, right = obs[self.bump_at : self.bump_at + 2] > 0.5
        pressed = {"left"} if left else set()
        pressed |= {"right"} if right else set()
        if self.state == "forward" and pressed:
            self.state, self.left, self.hit = "back", self.bt.BACK_TIME, set()
        if self.state == "back":
            self.hit |= pressed
            if self.left <= 0.0:
                self.rate = -self.bt.TURN_SPEED if self.hit == {"left"} else self.bt.TURN_SPEED
                self.state, self.left = "turn", self.rng.uniform(*self.bt.TURN_ANGLES) / self.bt.TURN_SPEED
        elif self.state == "turn" and self.left <= 0.0:
            self.state = "forward"
        self.left -= self.dt
        speeds = {"forward": (self.bt.FORWARD_SPEED, 0.0), "back": (self.bt.BACK_SPEED, 0.0), "turn": (0.0, self.rate)}
        return np.array(speeds[self.state], dtype=np.float32)


# ------------------------------------------------------------------------------ episodes
def make_env(**overrides: Any) -> CreateNavEnv:
    """The training env (:data:`ENV_KWARGS`, ``overrides`` on top)."""
    return CreateNavEnv(**(ENV_KWARGS | overrides))


def new_policy(env: CreateNavEnv, hidden: Sequence[int] = HIDDEN) -> MlpPolicy:
    """A zero policy for ``env`` that remembers the env's id and options."""
    return MlpPolicy.for_env(env, hidden=hidden, env_id=ENV_ID, **ENV_KWARGS)


def rollout(env: CreateNavEnv, controller: Controller, seed: int, collisions_end: bool = True) -> Episode:
    """One episode from ``reset(seed=seed)``. ``collisions_end=False`` plays on after a collision
    (as the ROS world does: ``robot_sims batch`` counts collisions and bumps) until the goal or
    ``max_steps``."""
    obs, _ = env.reset(seed=seed)
    controller.reset(seed)
    total, bumps, collisions, was_bumped, was_touching = 0.0, 0, 0, False, False
    backward, contact, speeds = 0, 0, 0.0
    for _ in range(env.max_steps):
        action = controller.act(obs)
        obs, reward, _, _, info = env.step(action)
        total += reward
        assert env.model is not None  # reset made it
        v = env.model.command[0]  # the applied forward speed (clamped per wheel)
        speeds += v
        backward += v < 0.0
        contact += info["collided"]
        bumps += info["bumped"] and not was_bumped
        collisions += info["collided"] and not was_touching
        was_bumped, was_touching = info["bumped"], info["collided"]
        if info["is_success"] or (info["collided"] and collisions_end):
            break
    steps = env.steps
    return Episode(
        total,
        bool(info["is_success"]),
        steps * env.substeps / 100.0,
        bumps,
        collisions,
        steps,
        backward,
        contact,
        speeds / max(steps, 1),
    )


def evaluate(
    controller: Controller, seeds: Sequence[int], env: CreateNavEnv | None = None, collisions_end: bool = True
) -> dict[str, float]:
    """Over ``seeds``: success rate, mean return, mean time to the goal (s, of the successes; NaN:
    none), mean collisions and bumps per episode, the share of steps driven backwards and spent
    touching a wall, and the mean commanded forward speed (m/s)."""
    env = env or make_env()
    episodes = [rollout(env, controller, seed, collisions_end) for seed in seeds]
    times = [e.time_s for e in episodes if e.success]
    steps = max(sum(e.steps for e in episodes), 1)
    return {
        "success_rate": float(np.mean([e.success for e in episodes])),
        "mean_return": float(np.mean([e.ret for e in episodes])),
        "mean_time_to_goal_s": float(np.mean(times)) if times else math.nan,
        "mean_collisions": float(np.mean([e.collisions for e in episodes])),
        "mean_bumps": float(np.mean([e.bumps for e in episodes])),
        "backward_share": sum(e.backward_steps for e in episodes) / steps,
        "contact_share": sum(e.contact_steps for e in episodes) / steps,
        "mean_v_mps": sum(e.mean_v * e.steps for e in episodes) / steps,
    }


# ------------------------------------------------------------------------------ training
_WORKER: dict[str, Any] = {}


def _init_worker(hidden: tuple[int, ...], env_overrides: dict[str, Any]) -> None:
    worker_signals()  # the pool's terminate() ends us even when this program caught SIGTERM
    env = make_env(**env_overrides)
    _WORKER.update(env=env, policy=new_policy(env, hidden))


def _fitness(job: tuple[np.ndarray, Sequence[int]]) -> tuple[float, float]:
    """A candidate's (mean return, success rate) over the generation's seeds (in a worker)."""
    params, seeds = job
    env, controller = _WORKER["env"], PolicyController(_WORKER["policy"].with_params(params))
    episodes = [rollout(env, controller, seed) for seed in seeds]
    return float(np.mean([e.ret for e in episodes])), float(np.mean([e.success for e in episodes]))


@dataclass
class TrainConfig:
    minutes: float = 15.0
    seed: int = 0
    hidden: tuple[int, ...] = HIDDEN
    episodes: int = 8  # per candidate and generation
    popsize: int = 16
    sigma0: float = 0.5
    workers: int = 2
    max_generations: int | None = None
    #: The search starts from a policy that drives forwards and turns towards the goal's bearing
    #: (:func:`initial_params`; 0: from all-zero weights). The LIDAR looks forwards (240°, blind
    #: behind): from all-zero weights CMA-ES settled on driving backwards, into walls it cannot see.
    head_for_goal: float = 1.0
    #: Start from this policy's weights instead (a file of the same shape, e.g. to go on training
    #: it with noise).
    init: MlpPolicy | None = None
    #: On top of :data:`ENV_KWARGS` while training only (e.g. a fixed start and goal); not saved.
    env_overrides: dict[str, Any] = field(default_factory=dict)


def train(config: TrainConfig, log: Callable[[str], None] = print) -> tuple[MlpPolicy, list[dict[str, float]]]:
    """CMA-ES until ``config.minutes`` (wall clock) or ``max_generations``; returns the best mean
    (CMA-ES's own estimate of the optimum) as a policy and each generation's figures."""
    start = time.perf_counter()
    policy = new_policy(make_env(), config.hidden)
    options = {"popsize": config.popsize, "seed": config.seed + 1, "verbose": -9}
    x0 = config.init.params() if config.init is not None else initial_params(policy, config.head_for_goal)
    es = cma.CMAEvolutionStrategy(x0, config.sigma0, options)
    rng = np.random.default_rng(config.seed)
    history: list[dict[str, float]] = []
    with _pool(config) as pool:
        while not _done(config, start, len(history)):
            seeds = rng.integers(EVAL_SEED0, size=config.episodes).tolist()
            candidates = es.ask()
            results = pool.map(_fitness, [(c, seeds) for c in candidates])
            es.tell(candidates, [-ret for ret, _ in results])
            history.append(_generation(len(history), results, time.perf_counter() - start))
            log(_progress(history[-1]))
    return policy.with_params(es.result.xfavorite), history


def initial_params(policy: MlpPolicy, gain: float) -> np.ndarray:
    """The search's first mean: a policy that heads for the goal, ``gain`` its strength (0: all
    weights 0). Its first hidden unit follows the goal's bearing (scaled to [-1, 1]) and drives the
    turn rate; the ``v`` output's bias drives forwards (``tanh(gain)``: 0.38 m/s at 1); every other
    weight 0. Needs a hidden layer and the ``goal`` sensor (the bearing is the observation's last)."""
    params = np.zeros(policy.n_params)
    if gain == 0.0:
        return params
    if len(policy.weights) < 2:
        raise ValueError("head_for_goal needs a hidden layer (--hidden N ...)")
    weights = [np.zeros_like(w) for w in policy.weights]
    biases = [np.zeros_like(b) for b in policy.biases]
    weights[0][-1, 0] = 2.0 * gain  # hidden unit 0 ← the goal's bearing
    for layer in range(1, len(weights) - 1):
        weights[layer][0, 0] = 2.0 * gain  # passed on through deeper hidden layers
    weights[-1][0, 1] = 2.0 * gain  # turn rate ← hidden unit 0
    biases[-1][0] = gain  # forwards
    return np.concatenate([a.ravel() for w, b in zip(weights, biases, strict=True) for a in (w, b)])


def _pool(config: TrainConfig):
    context = multiprocessing.get_context("fork" if sys.platform == "linux" else "spawn")
    return context.Pool(config.workers, _init_worker, (tuple(config.hidden), config.env_overrides))


def _done(config: TrainConfig, start: float, generations: int) -> bool:
    if config.max_generations is not None and generations >= config.max_generations:
        return True
    return time.perf_counter() - start >= 60.0 * config.minutes


def _generation(index: int, results: list[tuple[float, float]], elapsed: float) -> dict[str, float]:
    returns, successes = np.array(results).T
    return {
        "generation": index,
        "mean_return": float(returns.mean()),
        "best_return": float(returns.max()),
        "success_rate": float(successes.mean()),
        "elapsed_s": elapsed,
    }


def _progress(g: dict[str, float]) -> str:
    return (
        f"gen {g['generation']:4d}  {g['elapsed_s']:6.0f} s  mean return {g['mean_return']:7.2f}  "
        f"best {g['best_return']:7.2f}  success {100 * g['success_rate']:5.1f} %"
    )


# ------------------------------------------------------------------------------ command line
def _args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=15.0, help="wall-clock training budget")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name("create_nav_policy.npz"))
    parser.add_argument("--workers", type=int, default=2, help="worker processes (one per core)")
    parser.add_argument("--episodes", type=int, default=8, help="episodes per candidate and generation")
    parser.add_argument("--popsize", type=int, default=16)
    parser.add_argument("--hidden", type=int, nargs="*", default=list(HIDDEN), help="hidden layer sizes (none: linear)")
    parser.add_argument(
        "--head-for-goal",
        type=float,
        default=1.0,
        help="start from a policy that drives forwards, turning towards the goal, this strong (0: all-zero weights)",
    )
    parser.add_argument("--init", type=Path, help="start from this policy file's weights (same shape)")
    parser.add_argument("--sigma0", type=float, default=0.5, help="CMA-ES's first step size")
    parser.add_argument("--eval-episodes", type=int, default=50, help="held-out seeds for the final table")
    parser.add_argument("--evaluate", type=Path, help="only evaluate this policy file")
    parser.add_argument(
        "--noise", type=Path, help="a noise config to train (and also evaluate) with; the policy file does not keep it"
    )
    return parser.parse_args(argv)


def report(policy: MlpPolicy, episodes: int, noise: Path | None = None, log: Callable[[str], None] = print) -> None:
    """The policy against bump-and-turn and random actions on the same held-out seeds, both ways
    of counting collisions; noise-free, and with the ``noise`` config if given."""
    seeds = range(EVAL_SEED0, EVAL_SEED0 + episodes)
    envs = {"noise-free": make_env()} | ({f"noise {noise}": make_env(config_file=noise)} if noise else {})
    for label, env in envs.items():
        rivals: dict[str, Controller] = {
            "policy": PolicyController(policy),
            "bump_turn": BumpTurnController(env),
            "random": RandomController(env),
        }
        for collisions_end, title in (
            (True, "a collision ends the episode (the env)"),
            (False, "collisions counted, driving on (as batch)"),
        ):
            log(f"{episodes} seeds, 60 s, {label}, {title}:")
            for name, controller in rivals.items():
                r = evaluate(controller, seeds, env, collisions_end)
                log(
                    f"  {name:10s} success {100 * r['success_rate']:5.1f} %  return {r['mean_return']:7.2f}  "
                    f"time to goal {r['mean_time_to_goal_s']:5.1f} s  collisions {r['mean_collisions']:.2f}  "
                    f"bumps {r['mean_bumps']:.2f}  backwards {100 * r['backward_share']:5.1f} %  "
                    f"touching a wall {100 * r['contact_share']:5.1f} %  mean v {r['mean_v_mps']:+.2f} m/s"
                )


def main(argv: Sequence[str] | None = None) -> int:
    args = _args(argv)
    if args.evaluate is not None:
        report(load_policy(args.evaluate), args.eval_episodes, args.noise)
        return 0
    overrides = {"config_file": str(args.noise)} if args.noise else {}
    config = TrainConfig(
        args.minutes,
        args.seed,
        tuple(args.hidden),
        args.episodes,
        args.popsize,
        workers=args.workers,
        sigma0=args.sigma0,
        head_for_goal=args.head_for_goal,
        init=load_policy(args.init) if args.init else None,
        env_overrides=overrides,
    )
    policy, _ = train(config)
    print(f"wrote {policy.save(args.out)}")
    report(policy, args.eval_episodes, args.noise)
    return 0


if __name__ == "__main__":
    sys.exit(main())
