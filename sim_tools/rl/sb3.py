"""A Stable-Baselines3 policy as one of our policy files (``pip install -e '.[sb3]'``).

:func:`export_sb3` writes a trained SB3 PPO or A2C model (its ``MlpPolicy``: the default
``FlattenExtractor``, ``tanh`` or ``ReLU`` layers) as a :mod:`sim_tools.rl.policy` file, so it runs
where ours run: ``policy.act(obs)`` in the env, ``robot_sims policy_controller`` against the ROS
world and ``robot_sims batch``. The file acts as SB3's ``model.predict(obs, deterministic=True)``
does (the Gaussian's mean, clipped to the model's action space), mapped onto the env's action bounds
in the robot's units: the same command whether the model learned with ``normalize_actions=True``
(``[-1, 1]``, what SB3 advises) or in m/s and rad/s.

    model = PPO("MlpPolicy", gymnasium.make("robot_sims/CreateNav-v0", normalize_actions=True)).learn(100_000)
    export_sb3(model, "nav.npz", "robot_sims/CreateNav-v0", normalize_actions=True)

    python -m sim_tools.rl.sb3 model.zip nav.npz --env-kwargs '{"normalize_actions": true}'

``env_kwargs`` are the env's options the model learned with (sensors, LIDAR beams, control
period...): the file keeps them (without ``normalize_actions``: the file's actions are in the
robot's units), and the policy controller builds its observation from them. Not covered: observation
normalisation outside the env (``VecNormalize``), recurrent or image policies, SAC/TD3 (their
actor is another network): :class:`~sim_runtime.errors.InputError` says so.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sim_runtime.errors import InputError
from sim_tools.rl.policy import MlpPolicy

#: SB3 algorithms whose policy is an ``ActorCriticPolicy`` (the mean of a Gaussian over actions).
ALGORITHMS = ("PPO", "A2C")


def from_sb3(model: Any, env_id: str, **env_kwargs: Any) -> MlpPolicy:
    """The SB3 ``model`` (a PPO or A2C instance) as an :class:`MlpPolicy` for ``env_id`` built with
    ``env_kwargs``; InputError for a model or env this cannot carry over."""
    import gymnasium
    from torch import nn

    import sim_tools.rl  # noqa: F401 (registers the ids)

    name = type(model).__name__
    if name not in ALGORITHMS:
        raise InputError(f"a {name} model: export_sb3 takes {', '.join(ALGORITHMS)} (an actor-critic MlpPolicy)")
    policy = model.policy
    if type(policy.features_extractor).__name__ != "FlattenExtractor":
        raise InputError(f"{type(policy.features_extractor).__name__}: export_sb3 takes the default FlattenExtractor")
    env = gymnasium.make(env_id, **env_kwargs).unwrapped
    physical: Any = getattr(env, "physical_action_space", env.action_space)  # a Box: ours all are
    if model.observation_space.shape != env.observation_space.shape:
        raise InputError(
            f"the model observes {model.observation_space.shape}, {env_id} with {env_kwargs} gives "
            f"{env.observation_space.shape}: give the env options it learned with"
        )
    weights, biases, activations = [], [], set()
    for module in policy.mlp_extractor.policy_net:
        if isinstance(module, nn.Linear):
            weights.append(module.weight.detach().cpu().numpy().astype(float).T)
            biases.append(module.bias.detach().cpu().numpy().astype(float))
        elif isinstance(module, nn.Tanh | nn.ReLU):
            activations.add("tanh" if isinstance(module, nn.Tanh) else "relu")
        else:
            raise InputError(f"a {type(module).__name__} layer: export_sb3 takes Linear layers with Tanh or ReLU")
    if len(activations) > 1:
        raise InputError("Tanh and ReLU mixed: export_sb3 takes one activation")
    head = policy.action_net
    w, b = head.weight.detach().cpu().numpy().astype(float).T, head.bias.detach().cpu().numpy().astype(float)
    # SB3 clips the mean to the model's action space [lo, hi]; ours clips to [-1, 1], then maps that
    # onto the env's bounds in the robot's units: the same line, folded into the last layer.
    lo, hi = np.asarray(model.action_space.low, dtype=float), np.asarray(model.action_space.high, dtype=float)
    scale = 2.0 / (hi - lo)
    weights.append(w * scale)
    biases.append((b - lo) * scale - 1.0)
    n_obs = int(np.prod(env.observation_space.shape or ()))
    kept = {k: v for k, v in env_kwargs.items() if k != "normalize_actions"}
    return MlpPolicy(
        tuple(weights),
        tuple(biases),
        np.zeros(n_obs),
        np.ones(n_obs),
        np.asarray(physical.low, dtype=float),
        np.asarray(physical.high, dtype=float),
        env_id=env_id,
        env_kwargs=_plain(kept),
        activation=activations.pop() if activations else "tanh",
        output="clip",
    )


def export_sb3(model: Any, path: str | Path, env_id: str, **env_kwargs: Any) -> Path:
    """Write the SB3 ``model`` (an instance, or the path of its ``.zip``) as a policy file at
    ``path`` (see the module's docstring); returns the path."""
    if isinstance(model, str | Path):
        model = load_sb3(model)
    return from_sb3(model, env_id, **env_kwargs).save(path)


def load_sb3(path: str | Path) -> Any:
    """The PPO or A2C model saved in ``path`` (SB3's ``.zip``), on the CPU."""
    import stable_baselines3

    for name in ALGORITHMS:
        try:
            return getattr(stable_baselines3, name).load(str(path), device="cpu")
        except (KeyError, ValueError, TypeError, AssertionError):
            continue  # another algorithm's file
    raise InputError(f"{path}: not a {' or '.join(ALGORITHMS)} model saved by Stable-Baselines3")


def _plain(options: dict[str, Any]) -> dict[str, Any]:
    """Options as JSON keeps them (tuples → lists, paths → strings)."""
    return json.loads(json.dumps(options, default=str))


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim_tools.rl.sb3", description=__doc__.split("\n\n")[0])
    parser.add_argument("model", type=Path, help="the SB3 model's .zip (PPO or A2C)")
    parser.add_argument("out", type=Path, help="the policy file to write (.npz)")
    parser.add_argument("--env", default="robot_sims/CreateNav-v0", help="the env id it learned in")
    parser.add_argument("--env-kwargs", default="{}", help="the env's options it learned with, as JSON")
    args = parser.parse_args(argv)
    try:
        options = json.loads(args.env_kwargs)
        if not isinstance(options, dict):
            raise InputError(f"--env-kwargs {args.env_kwargs}: a JSON object")
        print(f"wrote {export_sb3(args.model, args.out, args.env, **options)}")
    except (InputError, json.JSONDecodeError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
