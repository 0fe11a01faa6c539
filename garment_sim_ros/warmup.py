"""Compile every numba kernel once, into the on-disk cache (``cache=True``).

``make venv`` runs ``python -m garment_sim_ros.warmup`` after installing, so the node's first
frame on a fresh machine does not wait for JIT compilation (tens of seconds on 2 cores), and the
garments are dressed and stepped without a compile pause showing up as lag.
"""

from __future__ import annotations

import sys
import time

from .body.pose_buffer import PoseBuffer
from .body.sources import procedural_source
from .collision.collider import PARALLEL_MIN_POINTS
from .dressing import make_character
from .params import DEFAULT_PARAMS
from .rerun_log import frame_payload
from .runtime.marker_cdr import serialize_marker_array
from .runtime.markers import frame_markers


def warm_up() -> float:
    """Run every hot path once (both collision paths: serial and, above PARALLEL_MIN_POINTS, parallel; the fused
    frame and the reference loop)."""
    tic = time.perf_counter()
    source = procedural_source("walk")
    for garments, resolution in ((["pants"], 1.0), (["one_piece"], 2.0)):
        character = make_character(source.rest_pose, source.joint_map, garments, DEFAULT_PARAMS, resolution)
        character.dress(source.pose(0.0), 0.0, settle_s=1.0 / 60.0)
        for k in range(1, 5):
            if k == 4:  # the reference loop's kernels too (``cloth.fused`` falls back to it)
                for solver in character.solvers:
                    solver.use_fused = False
            t = k / 60.0
            pose = source.pose(t)
            character.step(pose, source.motion(t), t)
        character.max_penetration()
        serialize_marker_array(frame_markers(frame_payload(character, pose), "warmup", "world", (0, 0), True))
    assert any(s.model.num_points >= PARALLEL_MIN_POINTS for s in character.solvers)
    buffer = PoseBuffer("world")
    translations, rotations = source.local_transforms(0.0)
    for i, name in enumerate(source.skeleton.names):
        parent = source.skeleton.parents[i]
        buffer.add_transform(0.0, "world" if parent < 0 else source.skeleton.names[parent], name,
                             translations[i], rotations[i])
    buffer.sample(0.0, source.skeleton)
    return time.perf_counter() - tic


def main() -> int:
    print(f"garment_sim_ros: numba kernels compiled and cached in {warm_up():.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
