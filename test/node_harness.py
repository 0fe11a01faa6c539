"""Test helpers for garment_sim_node in-process (shared by test_node, test_robustness, test_soak).

- ``Graph`` (the ``graph`` fixture of ``conftest.py``): a ``SingleThreadedExecutor`` over the test's nodes in the test's
  own rclpy context (``ros_context``), spun until a condition holds; destroys the nodes at the end.
- ``SkeletonPublisher``: plays ``ProceduralCharacter(walk())`` on /tf at 60 Hz, frames named
  ``prefix + joint``; ``running`` switches it off and on, ``prefix`` can change mid-run.
- ``Probe``: collects a node's raw marker messages and the /diagnostics statuses.
- ``garment_node(graph, **parameters)``, ``running(node, frames)``, ``feed(buffer, t)`` (the walker's
  transforms at ``t`` straight into a ``PoseBuffer``), ``transform(...)``, ``ros_time((sec, nanosec))``.
"""

from __future__ import annotations

import time

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TransformStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from garment_sim_ros.body.pose_buffer import PoseBuffer
from garment_sim_ros.body.procedural import ProceduralCharacter, walk
from garment_sim_ros.ros.node import GarmentSimNode
from garment_sim_ros.runtime.character_loop import Status

CHARACTER = ProceduralCharacter(walk())


def transform(stamp, parent: str, child: str, xyz, xyzw) -> TransformStamped:
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id, t.child_frame_id = parent, child
    tr, r = t.transform.translation, t.transform.rotation
    tr.x, tr.y, tr.z = (float(v) for v in xyz)
    r.x, r.y, r.z, r.w = (float(v) for v in xyzw)
    return t


class SkeletonPublisher:
    """Publishes the walking character's joints on /tf at 60 Hz, frames named ``prefix + joint``
    (``names``: the joints' names, the walker's by default), the root offset by ``offset`` in the
    world; ``running`` switches it on and off."""

    def __init__(self, context, prefix: str = "", offset=(0.0, 0.0, 0.0), name: str = "skeleton_player"):
        self.node = rclpy.create_node(name, context=context)
        self.prefix, self.offset = prefix, np.asarray(offset, float)
        self.names = CHARACTER.skeleton.names
        self.publisher = self.node.create_publisher(TFMessage, "/tf", 100)
        self.running = True
        self.node.create_timer(1.0 / 60.0, self.tick)

    def message(self, stamp, t: float) -> TFMessage:
        translations, rotations = CHARACTER.local_transforms(t)
        translations = translations.copy()
        translations[0] += self.offset
        names, parents = self.names, CHARACTER.skeleton.parents
        return TFMessage(transforms=[
            transform(stamp, "world" if parents[i] < 0 else self.prefix + names[parents[i]], self.prefix + name,
                       translations[i], rotations[i])
            for i, name in enumerate(names)])

    def tick(self) -> None:
        if self.running:
            now = self.node.get_clock().now()
            self.publisher.publish(self.message(now.to_msg(), now.nanoseconds * 1e-9))


class Probe:
    """Collects the raw marker messages of one node and the /diagnostics statuses."""

    def __init__(self, context, markers_topic: str, name: str = "probe"):
        self.node = rclpy.create_node(name, context=context)
        self.markers: list[bytes] = []
        self.diagnostics: list[DiagnosticStatus] = []
        self.node.create_subscription(MarkerArray, markers_topic, self.markers.append, 10, raw=True)
        self.node.create_subscription(DiagnosticArray, "/diagnostics",
                                      lambda msg: self.diagnostics.extend(msg.status), 10)

    def last_markers(self) -> MarkerArray:
        return deserialize_message(self.markers[-1], MarkerArray)

    def statuses_of(self, node: GarmentSimNode) -> list[DiagnosticStatus]:
        name = f"garment_sim: {node.get_fully_qualified_name()}"
        return [s for s in self.diagnostics if s.name == name]


class Graph:
    """An executor over the test's nodes; destroys them at the end."""

    def __init__(self, context):
        self.context = context
        self.executor = SingleThreadedExecutor(context=context)
        self.nodes = []

    def add(self, node):
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def remove(self, node):
        self.nodes.remove(node)
        self.executor.remove_node(node)
        node.destroy_node()

    def spin_until(self, condition, timeout_s: float) -> bool:
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.02)
            if condition():
                return True
        return False

    def spin_for(self, seconds: float) -> None:
        self.spin_until(lambda: False, seconds)

    def close(self):
        for node in self.nodes:
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()


def garment_node(graph, name="garment_sim_node", namespace=None, **overrides) -> GarmentSimNode:
    parameters = [Parameter(k, value=v) for k, v in overrides.items()]
    kwargs = {"namespace": namespace} if namespace else {}
    return graph.add(GarmentSimNode(name, context=graph.context, parameter_overrides=parameters, **kwargs))


def running(node: GarmentSimNode, frames: int = 1):
    return lambda: node.loop.status == Status.RUNNING and node.stats.total_frames >= frames


def feed(buffer: PoseBuffer, t: float, names=CHARACTER.skeleton.names, offset=(0.0, 0.0, 0.0),
         root_rotation=None) -> None:
    """The walker's transforms at ``t`` into ``buffer``: joints called ``names``, the root moved by
    ``offset`` (and turned to ``root_rotation``, a quaternion, when given)."""
    translations, rotations = CHARACTER.local_transforms(t)
    translations, rotations = translations.copy(), rotations.copy()
    translations[0] += offset
    if root_rotation is not None:
        rotations[0] = root_rotation
    parents = CHARACTER.skeleton.parents
    for i, name in enumerate(names):
        buffer.add_transform(t, "world" if parents[i] < 0 else names[parents[i]], name, translations[i], rotations[i])


def ros_time(sec_nanosec) -> Time:
    return Time(sec=sec_nanosec[0], nanosec=sec_nanosec[1])
