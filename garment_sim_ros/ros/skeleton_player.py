"""``skeleton_player``: plays a motion source (a BVH clip or the procedural character) on /tf.

Every tick (``rate_hz``) one ``tf2_msgs/TFMessage`` carries one ``TransformStamped`` per joint:
parent joint -> joint (names with ``frame_prefix`` prepended), the root joint under
``fixed_frame``; all stamped with the node clock's now (real time, or /clock with use_sim_time).

Playback time starts at 0 on the first tick and advances ``speed`` times as fast as the clock
(``speed`` and ``rate_hz`` can change at run time; the playback time stays continuous). A clip that
does not loop holds its last frame once it ends, still stamped with the current time.

With ``record`` set, every message published is also written to a new rosbag2 at that path
(``record_storage``: mcap or sqlite3; ``runtime.bag_io``), recorded at its stamp: input for
``garment-sim replay`` and its tests, no ``ros2 bag`` needed.

    skeleton_player --ros-args -p bvh:=clip.bvh -p speed:=2.0 -p frame_prefix:=alice/
    skeleton_player --ros-args -p bvh:=clip.bvh -p record:=out/walk_bag
"""

from __future__ import annotations

import math
import re
import sys

import rclpy
from geometry_msgs.msg import TransformStamped
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import serialize_message
from tf2_msgs.msg import TFMessage

from ..body.sources import GAITS, MotionSource, bvh_source, procedural_source
from ..runtime.bag_io import STORAGES, TF_TYPE, BagError, BagWriter
from .spinning import spin_until_shutdown

NODE_NAME = "skeleton_player"
_FRAME_CHARS = re.compile(r"^[A-Za-z0-9_/.-]*$")  # tf frame names: no spaces, no quoting

# name -> (default, description, read_only, (low, high) for floats)
PARAMETERS: dict[str, tuple] = {
    "bvh": ("", "BVH clip to play (path); empty: the procedural character", True, None),
    "gait": ("walk", f"procedural character's gait, one of {', '.join(GAITS)} (ignored with bvh)", True, None),
    "loop": (True, "restart the clip after its last frame; false: hold the last frame", True, None),
    "speed": (1.0, "playback speed factor (2 or 3 to stress the solver)", False, (0.05, 10.0)),
    "keep_first_frame": (False, "play the clip's frame 0 even when it is a reference pose (a T-pose the motion "
                         "jumps away from), which is dropped by default", True, None),
    "rate_hz": (120.0, "publishing rate, Hz", False, (1.0, 1000.0)),
    "frame_prefix": ("", "prepended to every joint frame name (e.g. 'alice/'), not to fixed_frame", True, None),
    "fixed_frame": ("world", "frame the root joint is published under", True, None),
    "record": ("", "also write every /tf message to a new rosbag2 folder at this path; empty: no recording",
               True, None),
    "record_storage": ("mcap", f"storage of the recorded bag, one of {', '.join(STORAGES)}", True, None),
}


def refusal(name: str, value) -> str | None:
    """Why ``value`` is not allowed for parameter ``name``, or None when it is."""
    default, _, _, bounds = PARAMETERS[name]
    if type(value) is not type(default):
        return f"must be a {type(default).__name__}, got {type(value).__name__} {value!r}"
    if bounds is not None and not (math.isfinite(value) and bounds[0] <= value <= bounds[1]):
        return f"must be in [{bounds[0]}, {bounds[1]}], got {value!r}"
    if name == "gait" and value not in GAITS:
        return f"unknown gait {value!r}; allowed: {', '.join(GAITS)}"
    if name in ("frame_prefix", "fixed_frame") and not _FRAME_CHARS.match(value):
        return f"{value!r} has characters a tf frame name cannot have; allowed: letters, digits, _ / . -"
    if name == "fixed_frame" and not value:
        return "must not be empty"
    if name == "record_storage" and value not in STORAGES:
        return f"unknown storage {value!r}; allowed: {', '.join(STORAGES)}"
    return None


class SkeletonPlayer(Node):
    """Publishes a ``MotionSource`` on /tf. Raises ``ValueError`` on a bad parameter or an unreadable BVH."""

    def __init__(self, **node_kwargs):
        super().__init__(NODE_NAME, **node_kwargs)
        values = {}
        for name, (default, description, read_only, bounds) in PARAMETERS.items():
            descriptor = ParameterDescriptor(name=name, description=description, read_only=read_only)
            if bounds is not None:
                descriptor.floating_point_range = [FloatingPointRange(from_value=bounds[0], to_value=bounds[1])]
            try:
                values[name] = self.declare_parameter(name, default, descriptor).value
            except ParameterException as error:
                self.destroy_node()
                raise ValueError(f"{NODE_NAME}: parameter {name!r}: {error}") from None
            reason = refusal(name, values[name])
            if reason:
                self.destroy_node()
                raise ValueError(f"{NODE_NAME}: parameter {name!r}: {reason}")
        try:
            self.source: MotionSource = (
                bvh_source(values["bvh"], loop=values["loop"], keep_first_frame=values["keep_first_frame"])
                if values["bvh"] else procedural_source(values["gait"]))
        except (ValueError, OSError) as error:
            self.destroy_node()
            raise ValueError(f"{NODE_NAME}: cannot play bvh {values['bvh']!r}: {error}") from None
        self.speed = values["speed"]
        self._anchor_stamp_ns: int | None = None  # stamp of the last (re)anchoring, ns
        self._anchor_motion_s = 0.0  # playback time at that stamp
        self._ended_logged = False
        self._message = self._transforms_template(values["frame_prefix"], values["fixed_frame"])
        self.recording: BagWriter | None = None
        if values["record"]:
            try:
                self.recording = BagWriter(values["record"], values["record_storage"])
                self.recording.add_topic("/tf", TF_TYPE)
            except (BagError, OSError) as error:
                self.destroy_node()
                raise ValueError(f"{NODE_NAME}: cannot record to {values['record']!r}: {error}") from None
        self.publisher = self.create_publisher(TFMessage, "/tf", QoSProfile(depth=100))
        self.timer = self.create_timer(1.0 / values["rate_hz"], self._tick)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info(
            f"playing {self.source.name} ({len(self.source.skeleton.names)} joints) on /tf at "
            f"{values['rate_hz']:g} Hz, speed {self.speed:g}x, root under {values['fixed_frame']!r}")
        if self.source.dropped_reference_frame:
            self.get_logger().info(f"{self.source.name}: frame 0 is a reference pose the motion jumps away from; "
                                   "it is not played (parameter keep_first_frame to play it)")

    def _transforms_template(self, prefix: str, fixed_frame: str) -> TFMessage:
        """One TransformStamped per joint, frame names filled in; ticks only write stamps and poses."""
        skeleton = self.source.skeleton
        message = TFMessage()
        for name, parent in zip(skeleton.names, skeleton.parents):
            transform = TransformStamped()
            transform.header.frame_id = fixed_frame if parent < 0 else prefix + skeleton.names[parent]
            transform.child_frame_id = prefix + name
            message.transforms.append(transform)
        return message

    def motion_time(self, stamp_ns: int) -> float:
        """Playback time (s into the motion) that the message stamped ``stamp_ns`` shows."""
        if self._anchor_stamp_ns is None:
            return 0.0
        return self._anchor_motion_s + self.speed * (stamp_ns - self._anchor_stamp_ns) * 1e-9

    def _tick(self) -> None:
        now = self.get_clock().now()
        stamp_ns = now.nanoseconds
        if self._anchor_stamp_ns is None:
            self._anchor_stamp_ns = stamp_ns
        t = self.motion_time(stamp_ns)
        if self.source.duration is not None and t > self.source.duration and not self._ended_logged:
            self.get_logger().info(f"{self.source.name} ended after {self.source.duration:.2f} s; "
                                   "holding its last frame")
            self._ended_logged = True
        translations, rotations = self.source.local_transforms(t)
        stamp = now.to_msg()
        for transform, (x, y, z), (qx, qy, qz, qw) in zip(self._message.transforms, translations.tolist(),
                                                          rotations.tolist()):
            transform.header.stamp = stamp
            translation, rotation = transform.transform.translation, transform.transform.rotation
            translation.x, translation.y, translation.z = x, y, z
            rotation.x, rotation.y, rotation.z, rotation.w = qx, qy, qz, qw
        self.publisher.publish(self._message)
        if self.recording is not None:
            self.recording.write("/tf", stamp_ns, serialize_message(self._message))

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        for parameter in parameters:
            if parameter.name not in PARAMETERS:
                continue
            reason = refusal(parameter.name, parameter.value)
            if reason:
                return SetParametersResult(successful=False, reason=f"{parameter.name}: {reason}")
        for parameter in parameters:
            if parameter.name == "speed":
                stamp_ns = self.get_clock().now().nanoseconds
                if self._anchor_stamp_ns is not None:  # keep the playback time continuous
                    self._anchor_motion_s, self._anchor_stamp_ns = self.motion_time(stamp_ns), stamp_ns
                self.speed = parameter.value
            elif parameter.name == "rate_hz":
                self.destroy_timer(self.timer)
                self.timer = self.create_timer(1.0 / parameter.value, self._tick)
        return SetParametersResult(successful=True)

    def destroy_node(self) -> None:
        if getattr(self, "recording", None) is not None:
            self.recording.close()  # a complete bag: rosbags writes metadata.yaml on close
            self.recording = None
        super().destroy_node()


def main(args=None) -> int:
    """Console script ``skeleton_player``: spins until SIGINT or SIGTERM (exit 0); exit code 2 on a bad parameter
    or clip."""
    rclpy.init(args=args)
    try:
        try:
            node = SkeletonPlayer()
        except ValueError as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
        spin_until_shutdown(node)
        return 0
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
