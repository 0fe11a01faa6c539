"""/tf throughput of garment_sim_node (issue 17): JSON lines, one per configuration.

Three processes, as a real pipeline: a plain rclpy publisher (this script's ``publish`` mode: the
clip's messages serialized once by rclpy, restamped and published as bytes, so Python does not limit
the offered rate), the node dressing the first character by ``frame_prefix``, and this process
reading the node's /diagnostics and counting its marker arrays. The node simulates a one-piece.

Each line: characters, joints, rate_hz, transforms/s offered (published) and absorbed (decoded by the
node: its character's and the others'), the node's input lag (receive time - stamp, p50 and p99 over
the measured windows, ms), marker arrays/s, the node's fps and status.

    .venv/bin/python bench/tf_throughput.py                    # the issue's configurations
    .venv/bin/python bench/tf_throughput.py --characters 1 --joints 150 --rate 1000 --seconds 10
    .venv/bin/python bench/tf_throughput.py --node-param frame_retries:=0   # a node parameter changed
    TF_BENCH_DEBUG=1 ...   # also the node's log and every diagnostics window, on stderr
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
CLIP = REPO / "test" / "data" / "cc_cmu_07_01_walk.bvh"
CONFIGS = [(1, 142, 120.0), (4, 150, 240.0), (1, 150, 1000.0)]  # characters, joints, Hz (issue 17's targets)
WARM_UP_S = 6.0  # start, dress and settle before the measured windows
MAX_POSES = 480  # distinct messages per character, played forwards then backwards (no teleport at the loop):
# rclpy builds each once at ~3 ms, so start-up stays short at 1 kHz


def clip_messages(prefix: str, joints: int, rate_hz: float) -> list[bytes]:
    """The clip's first MAX_POSES TFMessages at ``rate_hz``, forwards then backwards, serialized, stamps zero;
    joints beyond the clip's are leaves under its root (as a rig's helper frames)."""
    from geometry_msgs.msg import TransformStamped
    from rclpy.serialization import serialize_message
    from tf2_msgs.msg import TFMessage

    from garment_sim_ros.body.sources import bvh_source

    source = bvh_source(str(CLIP), loop=False)  # a looping clip jumps back from its end to its start
    skeleton = source.skeleton
    names = [prefix + n for n in skeleton.names] + [f"{prefix}helper_{k}" for k in range(joints - len(skeleton.names))]
    parents = ["world" if p < 0 else prefix + skeleton.names[p] for p in skeleton.parents]
    parents += [names[0]] * (len(names) - len(parents))
    times = np.arange(MAX_POSES) / rate_hz
    if source.duration is not None:
        times = times[times <= source.duration]
    messages = []
    for t in np.concatenate([times, times[::-1][1:-1]]):
        translations, rotations = source.local_transforms(float(t))
        extra = len(names) - len(translations)
        translations = np.vstack([translations, np.tile([0.0, 0.0, 0.1], (extra, 1))])
        rotations = np.vstack([rotations, np.tile([0.0, 0.0, 0.0, 1.0], (extra, 1))])
        message = TFMessage()
        for parent, child, p, q in zip(parents, names, translations.tolist(), rotations.tolist()):
            transform = TransformStamped()
            transform.header.frame_id, transform.child_frame_id = parent, child
            tr, r = transform.transform.translation, transform.transform.rotation
            tr.x, tr.y, tr.z = p
            r.x, r.y, r.z, r.w = q
            message.transforms.append(transform)
        messages.append(serialize_message(message))
    return messages


def publish(characters: int, joints: int, rate_hz: float, seconds: float) -> None:
    """Publish the clip for each character (prefix c0/, c1/...) at ``rate_hz`` on /tf; print the count."""
    import rclpy
    from rclpy.qos import QoSProfile
    from tf2_msgs.msg import TFMessage

    from garment_sim_ros.runtime.tf_input import stamp_words

    rclpy.init()
    node = rclpy.create_node("tf_bench_publisher")
    publisher = node.create_publisher(TFMessage, "/tf", QoSProfile(depth=100))
    plays = [clip_messages(f"c{c}/", joints, rate_hz) for c in range(characters)]
    words = stamp_words(plays[0][0])  # every message of the clip has the same layout
    print("ready", flush=True)
    start = time.monotonic()
    sent = 0
    k = 0
    while time.monotonic() - start < seconds:
        now_ns = node.get_clock().now().nanoseconds
        for play in plays:
            data = bytearray(play[k % len(play)])
            view = np.frombuffer(data, dtype="<u4", count=len(data) // 4)
            view[words] = now_ns // 1_000_000_000
            view[words + 1] = now_ns % 1_000_000_000
            publisher.publish(bytes(data))
            sent += 1
        k += 1
        delay = start + k / rate_hz - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    elapsed = time.monotonic() - start
    print(json.dumps({"messages": sent, "seconds": elapsed, "transforms_per_s": sent * joints / elapsed}), flush=True)
    node.destroy_node()
    rclpy.shutdown()


def measure(characters: int, joints: int, rate_hz: float, seconds: float, node_params: tuple[str, ...] = ()) -> dict:
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from visualization_msgs.msg import MarkerArray

    env = os.environ.copy()
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env.setdefault("ROS_DOMAIN_ID", str(100 + os.getpid() % 100))  # off everyone's default domain
    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")})
    node = subprocess.Popen([sys.executable, "-m", "garment_sim_ros.ros.node", "--ros-args", "-p",
                             "frame_prefix:=c0/", "-p", "garments:=[one_piece]", "-p", "diagnostics_period:=1.0",
                             *[arg for param in node_params for arg in ("-p", param)]],
                            cwd=REPO, env=env,
                            stdout=subprocess.DEVNULL,
                            stderr=None if os.environ.get("TF_BENCH_DEBUG") else subprocess.DEVNULL)
    total_s = WARM_UP_S + seconds
    publisher = subprocess.Popen([sys.executable, __file__, "publish", "--characters", str(characters), "--joints",
                                  str(joints), "--rate", str(rate_hz), "--seconds", str(total_s + 2.0)],
                                 cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert publisher.stdout.readline().strip() == "ready", "the publisher did not start"
    rclpy.init()
    listener = rclpy.create_node("tf_bench_listener")
    markers: list[float] = []
    windows: list[tuple[float, dict]] = []
    listener.create_subscription(MarkerArray, "/garment_sim_node/markers", lambda _: markers.append(time.monotonic()),
                                 100, raw=True)
    listener.create_subscription(DiagnosticArray, "/diagnostics", lambda m: windows.extend(
        (time.monotonic(), {kv.key: kv.value for kv in s.values}) for s in m.status), 10)
    executor = SingleThreadedExecutor()
    executor.add_node(listener)
    start = time.monotonic()
    try:
        while time.monotonic() - start < total_s:
            executor.spin_once(timeout_sec=0.05)
    finally:
        executor.shutdown()
        listener.destroy_node()
        rclpy.shutdown()
        node.terminate()
        node.wait(10)
        offered = json.loads(publisher.communicate(timeout=60)[0].strip().splitlines()[-1])
    if os.environ.get("TF_BENCH_DEBUG"):
        for t, w in windows:
            keys = ("status", "fps", "tick_ms", "input_hz", "input_lag_p50_ms", "input_stored", "skeleton_age_s")
            print(round(t - start, 1), {k: w.get(k) for k in keys}, file=sys.stderr)
    measured = [w for t, w in windows if t > start + WARM_UP_S + 1.0]  # whole windows after the warm-up
    stored = [int(w.get("input_stored", 0)) + int(w.get("input_other_character", 0)) for t, w in windows]
    times = [t for t, _ in windows]
    first = next((i for i, t in enumerate(times) if t > start + WARM_UP_S), None)
    absorbed = ((stored[-1] - stored[first]) / (times[-1] - times[first])
                if first is not None and times[-1] > times[first] else 0.0)
    window_end = start + total_s
    return {
        "bench": "tf_throughput", "characters": characters, "joints": joints, "rate_hz": rate_hz,
        "offered_transforms_per_s": round(offered["transforms_per_s"]),
        "absorbed_transforms_per_s": round(absorbed),
        "input_lag_p50_ms": round(float(np.median([float(w["input_lag_p50_ms"]) for w in measured])), 1)
        if measured else None,
        "input_lag_p99_ms": round(max(float(w["input_lag_p99_ms"]) for w in measured), 1) if measured else None,
        "markers_per_s": round(sum(1 for t in markers if t > start + WARM_UP_S) / (window_end - start - WARM_UP_S), 1),
        "node_fps": round(float(np.median([float(w["fps"]) for w in measured])), 1) if measured else None,
        "status": measured[-1]["status"] if measured else "no diagnostics",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", nargs="?", default="measure", choices=("measure", "publish"))
    parser.add_argument("--characters", type=int)
    parser.add_argument("--joints", type=int)
    parser.add_argument("--rate", type=float)
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--sweep", action="store_true",
                        help="1 x 150 joints from 1 kHz, doubling the rate until the node stops keeping up")
    parser.add_argument("--node-param", action="append", default=[], metavar="NAME:=VALUE",
                        help="a parameter of the node (repeatable), e.g. frame_retries:=0")
    args = parser.parse_args()
    if args.mode == "publish":
        publish(args.characters, args.joints, args.rate, args.seconds)
        return
    configs = ([(args.characters or 1, args.joints or 142, args.rate or 120.0)]
               if args.characters or args.joints or args.rate else CONFIGS)
    if args.sweep:
        rate_hz = 1000.0
        while True:
            result = measure(1, 150, rate_hz, args.seconds, tuple(args.node_param))
            result["keeps_up"] = keeps_up(result)
            print(json.dumps(result), flush=True)
            if not result["keeps_up"] or rate_hz >= 16000:
                return
            rate_hz *= 2.0
    for characters, joints, rate_hz in configs:
        print(json.dumps(measure(characters, joints, rate_hz, args.seconds, tuple(args.node_param))), flush=True)


def keeps_up(result: dict) -> bool:
    """Issue 17's bar: everything offered absorbed, the newest pose at most two frames (35 ms) behind,
    markers at 55 per s or more."""
    return (result["absorbed_transforms_per_s"] >= 0.98 * result["offered_transforms_per_s"]
            and (result["input_lag_p99_ms"] or math.inf) <= 35.0 and result["markers_per_s"] >= 55.0)


if __name__ == "__main__":
    main()
