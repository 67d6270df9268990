"""The base every node needs: clock and stepping, parameters, QoS, TF, messages, paths, files, bags.

Imports no simulator."""

from sim_runtime.numba_cache import lock_numba_cache

lock_numba_cache()
