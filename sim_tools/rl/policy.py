"""A learned policy as one file: a small neural network in numpy and the environment it acts in.

The file is a ``.npz``: ``w0, b0, w1, b1, …`` (layer ``i`` maps ``(n_in,)`` to ``(n_out,)`` as
``x @ w_i + b_i``; ``activation`` after every hidden layer, ``tanh`` or ``relu``), ``obs_offset`` and
``obs_scale`` (an observation is scaled as ``(obs - obs_offset) / obs_scale`` first), and ``meta``:
JSON with ``env_id`` and ``env_kwargs`` (the environment's options: sensors, LIDAR beams, control
period...), ``activation`` and ``output``. The last layer's output, squashed into ``[-1, 1]`` by
``tanh`` (``output: "tanh"``, ours) or clipped there (``"clip"``: a Gaussian policy's mean, as
Stable-Baselines3's PPO acts, :mod:`sim_tools.rl.sb3`), is mapped onto the action space's
``[low, high]``: the robot's own units, whatever space the policy learned in.

The same file is read by the environment's users (``policy.act(obs)``), by
``robot_sims policy_controller`` (the policy as a ROS node) and by ``robot_sims batch``.

>>> import numpy as np
>>> p = MlpPolicy.zeros(obs_size=3, hidden=(4,), act_low=[-1.0, -2.0], act_high=[1.0, 2.0])
>>> p.n_params
26
>>> p.with_params(np.zeros(p.n_params)).act(np.ones(3)).tolist()
[0.0, 0.0]
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from sim_runtime.errors import InputError

#: The policy file's format version (``meta["format"]``): 2 added ``activation`` and ``output``.
FORMAT = 2
#: The formats this version reads (a format 1 file is tanh everywhere).
READS = (1, 2)
ACTIVATIONS = ("tanh", "relu")
OUTPUTS = ("tanh", "clip")


@dataclass(frozen=True)
class MlpPolicy:
    """Layers of ``activation(x @ w + b)``, the last squashed or clipped into ``[-1, 1]``
    (``output``); actions scaled onto ``[act_low, act_high]``."""

    weights: tuple[np.ndarray, ...]
    biases: tuple[np.ndarray, ...]
    obs_offset: np.ndarray
    obs_scale: np.ndarray
    act_low: np.ndarray
    act_high: np.ndarray
    env_id: str = ""
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    activation: str = "tanh"
    output: str = "tanh"

    def __post_init__(self) -> None:
        if self.activation not in ACTIVATIONS:
            raise InputError(f"policy activation {self.activation!r}: one of {list(ACTIVATIONS)}")
        if self.output not in OUTPUTS:
            raise InputError(f"policy output {self.output!r}: one of {list(OUTPUTS)}")

    @classmethod
    def zeros(
        cls,
        obs_size: int,
        hidden: Sequence[int],
        act_low: Sequence[float],
        act_high: Sequence[float],
        **meta: Any,
    ) -> MlpPolicy:
        """A policy of the given shape, all weights 0 (fill them with :meth:`with_params`)."""
        sizes = [obs_size, *hidden, len(act_low)]
        weights = tuple(np.zeros((a, b)) for a, b in itertools.pairwise(sizes))
        biases = tuple(np.zeros(b) for b in sizes[1:])
        ones = np.ones(obs_size)
        low, high = np.asarray(act_low, dtype=float), np.asarray(act_high, dtype=float)
        return cls(weights, biases, 0.0 * ones, ones, low, high, **meta)

    @classmethod
    def for_env(cls, env: Any, hidden: Sequence[int] = (16,), env_id: str = "", **env_kwargs: Any) -> MlpPolicy:
        """A zero policy for ``env``'s spaces; observations scaled by the space's finite bounds."""
        low = np.asarray(env.observation_space.low, dtype=float)
        high = np.asarray(env.observation_space.high, dtype=float)
        finite = np.isfinite(low) & np.isfinite(high) & (high > low)
        act = env.action_space
        policy = cls.zeros(low.size, hidden, act.low, act.high, env_id=env_id, env_kwargs=env_kwargs)
        offset = np.where(finite, 0.5 * (low + high), 0.0)
        scale = np.where(finite, 0.5 * (high - low), 1.0)
        return replace(policy, obs_offset=offset, obs_scale=scale)

    @property
    def n_params(self) -> int:
        return sum(w.size + b.size for w, b in zip(self.weights, self.biases, strict=True))

    def params(self) -> np.ndarray:
        """Every weight and bias, flat (the order :meth:`with_params` reads)."""
        return np.concatenate([a.ravel() for w, b in zip(self.weights, self.biases, strict=True) for a in (w, b)])

    def with_params(self, flat: np.ndarray) -> MlpPolicy:
        """This policy with the weights and biases taken from ``flat`` (length :attr:`n_params`)."""
        flat = np.asarray(flat, dtype=float)
        if flat.shape != (self.n_params,):
            raise InputError(f"policy parameters: {flat.shape}, expected ({self.n_params},)")
        weights, biases, at = [], [], 0
        for w, b in zip(self.weights, self.biases, strict=True):
            weights.append(flat[at : at + w.size].reshape(w.shape))
            at += w.size
            biases.append(flat[at : at + b.size].copy())
            at += b.size
        return replace(self, weights=tuple(weights), biases=tuple(biases))

    def act(self, obs: np.ndarray) -> np.ndarray:
        """The action for one observation: ``(n_obs,)`` → ``(n_act,)`` float32 in the action bounds."""
        x = (np.asarray(obs, dtype=float) - self.obs_offset) / self.obs_scale
        hidden = np.tanh if self.activation == "tanh" else _relu
        for w, b in zip(self.weights[:-1], self.biases[:-1], strict=True):
            x = hidden(x @ w + b)
        x = x @ self.weights[-1] + self.biases[-1]
        x = np.tanh(x) if self.output == "tanh" else np.clip(x, -1.0, 1.0)
        action = self.act_low + 0.5 * (x + 1.0) * (self.act_high - self.act_low)
        return action.astype(np.float32)

    def save(self, path: str | Path) -> Path:
        """Write the policy file (``.npz``); returns its path."""
        path = Path(path)
        meta = {
            "format": FORMAT,
            "env_id": self.env_id,
            "env_kwargs": self.env_kwargs,
            "activation": self.activation,
            "output": self.output,
        }
        arrays: dict[str, Any] = {f"w{i}": w for i, w in enumerate(self.weights)}
        arrays |= {f"b{i}": b for i, b in enumerate(self.biases)}
        arrays |= {"obs_offset": self.obs_offset, "obs_scale": self.obs_scale}
        arrays |= {"act_low": self.act_low, "act_high": self.act_high, "meta": np.array(json.dumps(meta))}
        with path.open("wb") as f:
            np.savez(f, **arrays)
        return path


def load_policy(path: str | Path) -> MlpPolicy:
    """The policy in ``path`` (written by :meth:`MlpPolicy.save`); a clear error for anything else."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            n = sum(1 for key in data.files if key.startswith("w"))
            weights = tuple(data[f"w{i}"] for i in range(n))
            biases = tuple(data[f"b{i}"] for i in range(n))
            arrays = {k: data[k] for k in ("obs_offset", "obs_scale", "act_low", "act_high")}
    except (OSError, KeyError, ValueError) as exc:
        raise InputError(f"{path}: not a policy file ({exc})") from None
    if meta.get("format") not in READS:
        raise InputError(f"{path}: policy format {meta.get('format')!r}, this version reads {list(READS)}")
    return MlpPolicy(
        weights,
        biases,
        **arrays,
        env_id=meta.get("env_id", ""),
        env_kwargs=meta.get("env_kwargs", {}),
        activation=meta.get("activation", "tanh"),
        output=meta.get("output", "tanh"),
    )


def _relu(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, 0.0)
