"""``garment-sim publish``: what handing one garment MarkerArray to DDS costs, two ways.

Per size, one TRIANGLE_LIST marker with per-vertex colours goes out on a real rclpy
publisher, alternately through the numpy CDR path (``MarkerData`` + ``serialize_marker_array``
+ ``publish(bytes)``) and the plain rclpy path (``Point``/``ColorRGBA`` objects +
``publish(msg)``). Medians over the repeats. No subscriber is attached: the figure is
what the node pays per frame, not the transport.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time

import numpy as np

HELP = "MarkerArray publishing cost: numpy CDR path against rclpy Point objects (medians, ms)"
DEFAULT_SIZES = (1_000, 10_000, 60_000)
WARMUP = 2


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="one JSON object per size instead of a table")
    parser.add_argument("--sizes", type=int, nargs="+", default=list(DEFAULT_SIZES), metavar="N",
                        help="vertex counts (default: %(default)s)")
    parser.add_argument("--repeats", type=int, default=15, help="timed publishes per path and size (default: 15)")
    parser.add_argument("--domain-id", type=int, default=None,
                        help="ROS domain id (default: $ROS_DOMAIN_ID, else 100 + pid %% 101); "
                             "discovery stays on localhost")


def _domain_id(requested: int | None) -> int:
    if requested is not None:
        domain_id, source = requested, "--domain-id"
    elif os.environ.get("ROS_DOMAIN_ID"):
        domain_id, source = os.environ["ROS_DOMAIN_ID"], "ROS_DOMAIN_ID"
    else:
        return 100 + os.getpid() % 101
    try:
        domain_id = int(domain_id)
    except ValueError:
        raise SystemExit(f"garment-sim publish: {source}={domain_id!r} is not an integer (allowed: 0..232)")
    if not 0 <= domain_id <= 232:
        raise SystemExit(f"garment-sim publish: {source}={domain_id} is out of range (allowed: 0..232)")
    return domain_id


def _median_ms(samples: list[float]) -> float:
    return statistics.median(samples[WARMUP:]) * 1e3


def _measure(publisher, n_vertices: int, repeats: int) -> dict:
    from garment_sim_ros.ros.marker_objects import marker_array_message
    from garment_sim_ros.runtime.marker_cdr import TRIANGLE_LIST, MarkerData, serialize_marker_array

    rng = np.random.default_rng(n_vertices)
    vertices = rng.normal(size=(n_vertices, 3))
    colors = rng.uniform(size=(n_vertices, 4)).astype(np.float32)

    def marker() -> MarkerData:
        return MarkerData(ns="garment", id=0, type=TRIANGLE_LIST, frame_id="world",
                          stamp=(1, 0), points=vertices, colors=colors)

    cdr, objects = [], []
    for _ in range(WARMUP + repeats):
        start = time.perf_counter()
        data = serialize_marker_array([marker()])
        publisher.publish(data)
        cdr.append(time.perf_counter() - start)

        start = time.perf_counter()
        publisher.publish(marker_array_message([marker()]))
        objects.append(time.perf_counter() - start)
    cdr_ms, objects_ms = _median_ms(cdr), _median_ms(objects)
    return {"vertices": n_vertices, "cdr_ms": round(cdr_ms, 4), "rclpy_points_ms": round(objects_ms, 3),
            "ratio": round(objects_ms / cdr_ms, 1), "message_bytes": len(data), "repeats": repeats}


def run(args: argparse.Namespace) -> int:
    if args.repeats < 1 or any(n < 0 for n in args.sizes):
        raise SystemExit("garment-sim publish: --repeats must be >= 1 and --sizes >= 0")
    domain_id = _domain_id(args.domain_id)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"

    from garment_sim_ros.ros.in_process import marker_publisher

    with marker_publisher("garment_sim_publish_bench", domain_id) as publisher:
        if not args.json:
            print(f"MarkerArray publish, one TRIANGLE_LIST marker with colours, domain {domain_id}, "
                  f"median of {args.repeats}")
            print(f"{'vertices':>9} {'cdr ms':>9} {'rclpy Point ms':>15} {'ratio':>7} {'bytes':>10}")
        for n_vertices in args.sizes:
            row = _measure(publisher, n_vertices, args.repeats)
            if args.json:
                print(json.dumps(row), flush=True)
            else:
                print(f"{row['vertices']:>9} {row['cdr_ms']:>9.3f} {row['rclpy_points_ms']:>15.2f} "
                      f"{row['ratio']:>6.0f}x {row['message_bytes']:>10}", flush=True)
    return 0
