"""The plain rclpy way to build a MarkerArray: one ``Point`` / ``ColorRGBA`` object per vertex.

The reference that ``marker_cdr`` is tested and benchmarked against; the node publishes
through ``marker_cdr`` instead, because this costs ~160 ms for 60 000 points.
"""

from __future__ import annotations

from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Point, Pose, Quaternion, Vector3
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from garment_sim_ros.runtime.marker_cdr import MarkerData


def _color(rgba) -> ColorRGBA:
    r, g, b, a = (float(v) for v in rgba)
    return ColorRGBA(r=r, g=g, b=b, a=a)


def marker_message(data: MarkerData) -> Marker:
    marker = Marker()
    marker.header.stamp = Time(sec=data.stamp[0], nanosec=data.stamp[1])
    marker.header.frame_id = data.frame_id
    marker.ns = data.ns
    marker.id = int(data.id)
    marker.type = int(data.type)
    marker.action = int(data.action)
    px, py, pz = (float(v) for v in data.position)
    qx, qy, qz, qw = (float(v) for v in data.orientation)
    marker.pose = Pose(position=Point(x=px, y=py, z=pz), orientation=Quaternion(x=qx, y=qy, z=qz, w=qw))
    sx, sy, sz = (float(v) for v in data.scale)
    marker.scale = Vector3(x=sx, y=sy, z=sz)
    marker.color = _color(data.color)
    marker.lifetime = Duration(sec=data.lifetime[0], nanosec=data.lifetime[1])
    marker.frame_locked = bool(data.frame_locked)
    if data.points is not None:
        marker.points = [Point(x=x, y=y, z=z) for x, y, z in data.points.astype(float).tolist()]
    if data.colors is not None:
        # float32 first: ColorRGBA holds float32, and the CDR path writes float32.
        marker.colors = [ColorRGBA(r=r, g=g, b=b, a=a) for r, g, b, a in data.colors.astype("f4").tolist()]
    return marker


def marker_array_message(markers: list[MarkerData]) -> MarkerArray:
    return MarkerArray(markers=[marker_message(m) for m in markers])
