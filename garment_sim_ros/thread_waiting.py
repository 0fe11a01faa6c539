"""numba's OpenMP threads wait asleep between parallel loops, not spinning.

GNU OpenMP, numba's threading layer where libgomp is present, keeps a thread spinning for a while after
each parallel loop. On cores shared with other busy processes (a ROS pipeline: the skeleton publisher,
rviz, another node), a spinning thread holds the core its partner needs, and every loop's barrier then
waits for the scheduler: a 4096-element ``prange`` took 5.8 ms per launch at load 5.6, against 3.9 us
with ``OMP_WAIT_POLICY=passive`` in the same minute (the drape scene, n = 64, whose collision drivers
run on both threads: 873 ms per frame against 38 ms). libgomp reads the variable when it is loaded,
at numba's first parallel loop, so it is set on import, before any kernel runs; a value the user set
is kept.
"""

from __future__ import annotations

import os

WAIT_POLICY = "OMP_WAIT_POLICY"


def prefer_passive_waiting(environ=os.environ) -> str:
    """Set ``OMP_WAIT_POLICY=passive`` unless it is set already; returns the policy in force."""
    return environ.setdefault(WAIT_POLICY, "passive")
