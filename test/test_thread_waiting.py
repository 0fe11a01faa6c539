"""numba's OpenMP threads are told to wait asleep (``garment_sim_ros.thread_waiting``)."""

import os
import subprocess
import sys

from garment_sim_ros.thread_waiting import WAIT_POLICY, prefer_passive_waiting

PROBE = "import os, garment_sim_ros; print(os.environ.get('OMP_WAIT_POLICY'))"


def _policy_after_import(environ: dict) -> str:
    result = subprocess.run([sys.executable, "-c", PROBE], env=environ, capture_output=True, text=True,
                            check=True)
    return result.stdout.strip()


def test_the_package_sets_passive_waiting_on_import():
    environ = {k: v for k, v in os.environ.items() if k != WAIT_POLICY}
    assert _policy_after_import(environ) == "passive"


def test_a_policy_the_user_set_is_kept():
    assert _policy_after_import({**os.environ, WAIT_POLICY: "active"}) == "active"


def test_prefer_passive_waiting_on_a_given_environment():
    environ = {}
    assert prefer_passive_waiting(environ) == "passive"
    assert environ == {WAIT_POLICY: "passive"}
    assert prefer_passive_waiting({WAIT_POLICY: "ACTIVE"}) == "ACTIVE"
