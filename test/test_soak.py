"""Soak: garment_sim_node with the walking character for thousands of frames (issue 7).

The node runs on sim time (``use_sim_time``) that the test advances itself, 60 frames per simulated
second, feeding /tf and firing the frame timer's callback directly: the node's whole frame path
(ingest, loop, solver, markers, statistics) runs, faster than real time and without an executor's
scheduling noise. Every ``PARAMETER_PERIOD_S`` a parameter changes (through ``set_parameters``,
validated like the parameter services) and every ``RESTART_PERIOD_S`` the skeleton stops for
``RESTART_GAP_S`` and restarts. Asserted: no NaN, no free garment point deeper than 1 mm in a body
volume, the process's memory grows less than ``MEMORY_BOUND_MB`` after the warm-up, the frame
compute time stays within ``SLOWDOWN_BAND`` of the start's, and every restart dresses again.

Default: 40 s of simulated time (2400 frames, ~30 s here). A longer manual run:

    SOAK_SECONDS=600 .venv/bin/python -m pytest -q -s test/test_soak.py
"""

from __future__ import annotations

import math
import os

import numpy as np
import psutil
from node_harness import SkeletonPublisher
from rclpy.parameter import Parameter
from rclpy.time import Time

from garment_sim_ros.ros.node import GarmentSimNode
from garment_sim_ros.runtime.character_loop import Status
from garment_sim_ros.runtime.tf_input import seconds_to_stamp

SOAK_SECONDS = float(os.environ.get("SOAK_SECONDS", "40"))
RATE_HZ = 60.0
PARAMETER_PERIOD_S = 5.0
RESTART_PERIOD_S = 25.0  # the skeleton stops half-way through each period...
RESTART_GAP_S = 1.5  # ...for longer than RESUME_GAP_S: the garments are dressed again at the new pose
WINDOW_FRAMES = 120  # the statistics window (2 s of simulated time)
WARM_UP_S = 10.0  # numba caches, first dressing, first allocations
MEMORY_BOUND_MB = 30.0
SLOWDOWN_BAND = 2.0  # median frame compute time at the end / at the start
PENETRATION_BOUND_M = 0.001
PARAMETER_CYCLE = [("air_damping", 1.5), ("friction", 0.35), ("air_damping", 0.6), ("wind", [1.0, 0.5, 0.0]),
                   ("friction", 0.2), ("wind", [0.0, 0.0, 0.0]), ("substep", 0.004), ("substep", 0.005)]


def test_the_node_runs_thousands_of_frames_with_parameter_changes_and_restarts(ros_context):
    node = GarmentSimNode(context=ros_context, parameter_overrides=[Parameter("use_sim_time", value=True)])
    player = SkeletonPublisher(ros_context)  # only its messages: the test feeds them to the node
    clock = node.get_clock()
    try:
        frames = int(SOAK_SECONDS * RATE_HZ)
        tick_ms: list[float] = []  # median frame compute time per window
        penetration_mm = 0.0
        restarts = changes = 0
        rss_after_warm_up = None
        was_stopped = False
        for k in range(1, frames + 1):
            t = 1000.0 + k / RATE_HZ
            clock.set_ros_time_override(Time(nanoseconds=int(round(t * 1e9))))
            phase = (t - 1000.0) % RESTART_PERIOD_S - 0.5 * RESTART_PERIOD_S
            stopped = 0.0 <= phase < RESTART_GAP_S
            restarts += was_stopped and not stopped
            was_stopped = stopped
            if not stopped:
                sec, nanosec = seconds_to_stamp(t)
                node._on_tf(player.message(Time(seconds=sec, nanoseconds=nanosec).to_msg(), t))
            if k % int(PARAMETER_PERIOD_S * RATE_HZ) == 0:
                name, value = PARAMETER_CYCLE[changes % len(PARAMETER_CYCLE)]
                assert node.set_parameters([Parameter(name, value=value)])[0].successful
                changes += 1
            node._on_frame_timer()
            if k % WINDOW_FRAMES == 0:
                figures = node.stats.window()
                if t - 1000.0 > WARM_UP_S:
                    tick_ms.append(figures["tick_ms"])
                    penetration_mm = max(penetration_mm, figures["max_penetration_mm"])
                if rss_after_warm_up is None and t - 1000.0 > WARM_UP_S:
                    rss_after_warm_up = psutil.Process().memory_info().rss
                if node.loop.character is not None:
                    assert all(np.all(np.isfinite(p)) for p in node.loop.character.world_positions()), t
        grown_mb = (psutil.Process().memory_info().rss - rss_after_warm_up) / 1e6
        start, end = np.median(tick_ms[:5]), np.median(tick_ms[-5:])
        print(f"soak: {frames} frames, {node.stats.total_frames} simulated, {changes} parameter changes, "
              f"{restarts} restarts; max penetration {penetration_mm:.3f} mm; tick {start:.2f} -> {end:.2f} ms; "
              f"memory {grown_mb:+.1f} MB; loop {dict(node.loop.counts)}")
        assert node.frame_errors == 0 and node.loop.status == Status.RUNNING
        assert node.stats.total_frames > 0.8 * frames
        assert node.loop.counts["resumed_after_gap"] == restarts  # each restart dressed the garments again
        assert changes == math.floor(frames / (PARAMETER_PERIOD_S * RATE_HZ))
        name, value = PARAMETER_CYCLE[(changes - 1) % len(PARAMETER_CYCLE)]
        assert all(getattr(s.params, name) == (tuple(value) if isinstance(value, list) else value)
                   for s in node.loop.character.solvers)  # the last change reached the garments
        assert penetration_mm <= 1e3 * PENETRATION_BOUND_M, penetration_mm
        assert grown_mb < MEMORY_BOUND_MB, grown_mb
        assert end < SLOWDOWN_BAND * start, (start, end)
        node.publish_diagnostics()
        assert node.last_diagnostics["frame_errors"] == "0"
    finally:
        player.node.destroy_node()
        node.destroy_node()
