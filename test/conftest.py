"""Shared pytest fixtures.

``ros_context``: an rclpy context of its own for one test, on DDS kept on this machine.

    def test_talks(ros_context):
        node = rclpy.create_node("probe", context=ros_context)
        executor = rclpy.executors.SingleThreadedExecutor(context=ros_context)
        ...

- ``rclpy.init(context=ctx, domain_id=TEST_DOMAIN_ID)`` with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``
  and ``ROS_DOMAIN_ID`` set in the environment for the test's duration (so a subprocess
  the test starts joins the same domain, on this machine only).
- ``TEST_DOMAIN_ID`` (1..232) is the same for every test of a run and differs between concurrent
  runs on this machine: each run holds an exclusive lock on a file per domain for its whole life
  (two runs whose pids map to the same domain would otherwise hear each other's /tf and
  parameters).
- Pass the context to everything: ``create_node(..., context=)``, executors, ``rclpy.spin_once(...)``'s
  executor. The context is shut down after the test; destroy your nodes in the test
  (or a ``try/finally``) so their entities leave the graph first.
``graph``: a ``node_harness.Graph`` over ``ros_context`` (an executor spun until a condition holds),
closed after the test.

rclpy is imported only when a test asks for a fixture, so ROS-free tests do not load it.
"""

from __future__ import annotations

import fcntl
import os
import tempfile
from contextlib import contextmanager

import pytest


def _claim_domain_id():
    """A DDS domain id no other test run on this machine holds; the lock lives as long as the process."""
    # Fast DDS accepts domain ids 0..232; 0 is everyone's default, so stay off it.
    for k in range(232):
        domain = 1 + (os.getpid() + k) % 232
        lock = open(os.path.join(tempfile.gettempdir(), f"garment_sim_test_domain_{domain}.lock"), "w")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        return domain, lock
    raise RuntimeError("every DDS domain 1..232 is held by another test run on this machine")


TEST_DOMAIN_ID, _DOMAIN_LOCK = _claim_domain_id()


@contextmanager
def local_ros_context():
    """An rclpy context on this machine's test domain (the environment set for its duration)."""
    import rclpy
    from rclpy.context import Context

    with pytest.MonkeyPatch.context() as monkeypatch:
        monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        monkeypatch.setenv("ROS_DOMAIN_ID", str(TEST_DOMAIN_ID))
        context = Context()
        rclpy.init(context=context, domain_id=TEST_DOMAIN_ID)
        try:
            yield context
        finally:
            context.try_shutdown()


@pytest.fixture
def ros_context():
    with local_ros_context() as context:
        yield context


@pytest.fixture
def graph(ros_context):
    from node_harness import Graph  # imports rclpy: only for the tests that ask for this fixture

    g = Graph(ros_context)
    yield g
    g.close()
