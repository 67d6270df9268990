"""Learning environments over the pure models (``pip install -e '.[rl]'``; docs/learning.md).

Importing this package registers the Gymnasium ids (:mod:`sim_tools.rl.registration`).
"""

from sim_tools.rl.registration import register_envs

register_envs()
