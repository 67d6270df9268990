"""What a Create controller does, as ``robot_sims batch`` metrics of the learning example's sweeps
(``metrics: [nav_metrics:driving]``; the sweep's folder is on the import path).

:func:`driving`: the path driven forwards and backwards (m), the share of it driven backwards, and
the time spent with a wall touching the body (s): a robot pushing against a wall it cannot see
shows as contact time, not as distance.
"""

from __future__ import annotations

import numpy as np

from create_sim.model import CreateModel
from sim_tools.adapters.contract import EpisodeData


def driving(data: EpisodeData) -> dict[str, float]:
    """``forward_m``, ``backward_m`` (path length along and against the heading, from the pose
    after every physics step), ``backward_share`` (of the path) and ``wall_contact_s`` (time a wall
    touched the body, as ``collisions`` counts touches)."""
    x, y, theta = data.arrays["x"], data.arrays["y"], data.arrays["theta"]
    dx, dy = np.diff(x), np.diff(y)
    mid = theta[:-1] + 0.5 * np.angle(np.exp(1j * np.diff(theta)))
    along = dx * np.cos(mid) + dy * np.sin(mid)  # signed by the heading
    step = np.hypot(dx, dy)
    forward, backward = float(step[along > 0].sum()), float(step[along < 0].sum())
    dt = np.diff(data.t)
    touching = data.arrays["clearance"][1:] <= CreateModel.CONTACT_M
    return {
        "forward_m": forward,
        "backward_m": backward,
        "backward_share": backward / (forward + backward) if forward + backward > 0 else 0.0,
        "wall_contact_s": float(dt[touching].sum()),
    }
