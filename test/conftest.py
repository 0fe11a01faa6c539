"""Shared pytest fixtures.

``ros_context``: an rclpy context of its own for one test, on DDS kept on this machine.

    def test_talks(ros_context):
        node = rclpy.create_node("probe", context=ros_context)
        executor = rclpy.executors.SingleThreadedExecutor(context=ros_context)
        ...

- ``rclpy.init(context=ctx, domain_id=TEST_DOMAIN_ID)`` with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``
  and ``ROS_DOMAIN_ID`` set in the environment for the test's duration (so a subprocess
  the test starts joins the same domain, on this machine only).
- ``TEST_DOMAIN_ID`` (1..232, derived from the pid) is the same for every test of a run and
  differs between concurrent runs, so parallel runs and other ROS processes never cross-talk.
- Pass the context to everything: ``create_node(..., context=)``, executors, ``rclpy.spin_once(...)``'s
  executor. The context is shut down after the test; destroy your nodes in the test
  (or a ``try/finally``) so their entities leave the graph first.
``graph``: a ``node_harness.Graph`` over ``ros_context`` (an executor spun until a condition holds),
closed after the test.

rclpy is imported only when a test asks for a fixture, so ROS-free tests do not load it.
"""

from __future__ import annotations

import os
from contextlib import contextmanager

import pytest

# Fast DDS accepts domain ids 0..232; 0 is everyone's default, so stay off it.
TEST_DOMAIN_ID = 1 + os.getpid() % 232


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
