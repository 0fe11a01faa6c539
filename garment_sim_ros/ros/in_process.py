"""rclpy for the command line's in-process runs, each in its own context (a run leaves no global state):
``garment-sim demo`` (the node and the player on one executor) and ``garment-sim publish`` (a MarkerArray
publisher). The commands hold no rclpy themselves (``test/test_layers.py``)."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Iterator, Mapping

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from visualization_msgs.msg import MarkerArray

from .node import GarmentSimNode
from .skeleton_player import SkeletonPlayer


def _overrides(values: Mapping[str, Any]) -> list[Parameter]:
    return [Parameter(name, value=value) for name, value in values.items()]


@contextmanager
def node_and_player(node_parameters: Mapping[str, Any],
                    player_parameters: Mapping[str, Any]) -> Iterator[tuple[SingleThreadedExecutor, GarmentSimNode]]:
    """garment_sim_node and skeleton_player with these parameters, added to one executor: ``(executor, node)``;
    the caller spins the executor."""
    context = Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    player = SkeletonPlayer(context=context, parameter_overrides=_overrides(player_parameters))
    node = GarmentSimNode(context=context, parameter_overrides=_overrides(node_parameters))
    try:
        executor.add_node(player)
        executor.add_node(node)
        yield executor, node
    finally:
        executor.shutdown()
        for n in (player, node):
            n.destroy_node()
        context.try_shutdown()


@contextmanager
def marker_publisher(node_name: str, domain_id: int) -> Iterator[Any]:
    """A MarkerArray publisher on ``~/markers`` of a node ``node_name`` in ROS domain ``domain_id``; it takes
    messages or their CDR bytes."""
    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    try:
        node = rclpy.create_node(node_name, context=context)
        yield node.create_publisher(MarkerArray, "~/markers", 1)
        node.destroy_node()
    finally:
        context.try_shutdown()
