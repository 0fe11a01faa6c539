"""What ``garment-sim table1`` and ``garment-sim scale`` measure: one dressed character, frame by frame (ROS-free).

Per frame, timed separately, as the node does it:

- the simulation step (``DressedCharacter.step``): ``integration_ms`` is forces + explicit step +
  length correction (the memo's I), ``collision_ms`` the contact and full collision handling (its
  CH), both summed from the solver's own stage timers; ``step_ms`` is the step's wall time, so
  ``step_ms - integration_ms - collision_ms`` is the Python around the kernels;
- ``publish_ms``: normals, shaded colours and the MarkerArray CDR bytes of the garments and the
  volumes (``rerun_log.frame_payload`` + ``markers.frame_markers`` + ``serialize_marker_array``;
  handing the bytes to DDS is ``garment-sim publish``'s figure, not counted here);
- ``rerun_ms``: ``RerunLogger.log_frame`` of the same payload into a temporary ``.rrd``.

``total_ms`` is the median of the per-frame sum step + publish + rerun. Medians are over the
timed frames, after untimed warm-up frames. Pose sampling and root-motion estimation (the
node's input) are not timed. The machine's load average is recorded with each row because
the figures are wall times on a shared machine.
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .body.sources import procedural_source
from .dressing import make_character
from .params import SolverParams

MARKER_NAMESPACE = "garment"
FIXED_FRAME = "world"


def set_threads(count: int | None) -> int:
    """Numba's thread count for parallel kernels (``None``: leave it); returns the count in use."""
    import numba

    if count is not None:
        available = numba.config.NUMBA_NUM_THREADS
        if not 1 <= count <= available:
            raise ValueError(f"--threads {count}: allowed 1..{available} (numba's NUMBA_NUM_THREADS)")
        numba.set_num_threads(count)
    return numba.get_num_threads()


def load_average() -> float:
    """One-minute load average of the machine (what ``uptime`` shows first)."""
    return round(os.getloadavg()[0], 2)


def progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


@contextmanager
def call_timers(targets, clock=time.thread_time, key=lambda name, args: name):
    """Time every call of ``targets`` ((owner, attribute) pairs: module kernels, methods) while inside; yields
    ``totals``: ``key(attribute, args)`` -> [wall s, CPU s by ``clock``, calls]. The attributes are put back on
    exit. ``clock``: ``time.thread_time`` for the calling thread, ``time.process_time`` to count numba's
    worker threads too (a parallel kernel)."""
    totals: defaultdict = defaultdict(lambda: [0.0, 0.0, 0])
    originals = [(owner, name, getattr(owner, name)) for owner, name in targets]

    def timed(name, function):
        def call(*args, **kwargs):
            wall, cpu = time.perf_counter(), clock()
            result = function(*args, **kwargs)
            entry = totals[key(name, args)]
            entry[0] += time.perf_counter() - wall
            entry[1] += clock() - cpu
            entry[2] += 1
            return result
        return call

    for owner, name, function in originals:
        setattr(owner, name, timed(name, function))
    try:
        yield totals
    finally:
        for owner, name, function in originals:
            setattr(owner, name, function)


def _median_ms(samples: list[float]) -> float:
    return statistics.median(samples) * 1e3


def character_benchmark(garment: str, params: SolverParams, frame_s: float, frames: int, warmup: int,
                        resolution: float = 1.0, rerun: bool = True, gait: str = "walk",
                        forearms: bool = True) -> dict:
    """Dress the procedural character (``gait``) in ``garment`` at ``resolution`` and time ``frames``
    frames of ``frame_s`` seconds after ``warmup`` untimed ones (``forearms``: ``make_character``'s). Returns the
    per-frame medians."""
    from .rerun_log import RerunLogger, frame_payload
    from .runtime.marker_cdr import serialize_marker_array
    from .runtime.markers import frame_markers
    from .runtime.tf_input import seconds_to_stamp

    if frames < 1 or warmup < 0:
        raise ValueError(f"--frames must be >= 1 and --warmup >= 0, got {frames} and {warmup}")
    if not frame_s > 0.0:
        raise ValueError(f"frame time must be > 0 s, got {frame_s!r}")
    source = procedural_source(gait)
    character = make_character(source.rest_pose, source.joint_map, [garment], params, resolution,
                               motion=source.fit_poses(), forearms=forearms)
    solver = character.solvers[0]
    character.dress(source.pose(0.0), 0.0, source.motion(0.0))

    with tempfile.TemporaryDirectory(prefix="garment_sim_bench_") as folder:
        logger = RerunLogger("save", path=Path(folder) / "bench.rrd") if rerun else RerunLogger("off")
        samples: dict[str, list[float]] = {k: [] for k in
                                           ("integration", "collision", "step", "publish", "rerun", "total")}
        substeps = []
        worst_penetration = 0.0
        finite = True
        try:
            for frame in range(1, warmup + frames + 1):
                t = frame * frame_s
                pose = source.pose(t)
                motion = source.motion(t)
                tic = time.perf_counter()
                reports = character.step(pose, motion, t)
                toc = time.perf_counter()
                payload = frame_payload(character, pose)
                serialize_marker_array(frame_markers(payload, MARKER_NAMESPACE, FIXED_FRAME, seconds_to_stamp(t),
                                                     with_volumes=True))
                tac = time.perf_counter()
                integration = sum(r.integration_s + r.correction_s for r in reports)
                collision = sum(r.collision_s for r in reports)
                logger.log_frame(t, timings_ms={"integration": integration * 1e3, "collision": collision * 1e3,
                                                "publish": (tac - toc) * 1e3}, **payload)
                end = time.perf_counter()
                if frame <= warmup:
                    continue
                for key, value in (("integration", integration), ("collision", collision), ("step", toc - tic),
                                   ("publish", tac - toc), ("rerun", end - tac), ("total", end - tic)):
                    samples[key].append(value)
                substeps.append(reports[0].substeps)
                worst_penetration = max(worst_penetration, character.max_penetration())
                finite = finite and bool(np.all(np.isfinite(solver.state.positions)))
        finally:
            logger.close()

    model = solver.model
    counts = model.spring_counts()
    total_ms = _median_ms(samples["total"])
    step_ms = _median_ms(samples["step"])
    substeps_per_frame = statistics.median(substeps)
    return {
        "garment": garment,
        "resolution": resolution,
        "mass_points": model.num_points,
        "springs": sum(counts.values()),  # structural + shear + bend, as ``garment-sim garments`` counts
        "edges": counts["structural"],
        "volumes": len(character.body.volumes),
        "substeps_per_frame": substeps_per_frame,
        "integration_ms": round(_median_ms(samples["integration"]), 4),
        "collision_ms": round(_median_ms(samples["collision"]), 4),
        "step_ms": round(step_ms, 4),
        "publish_ms": round(_median_ms(samples["publish"]), 4),
        "rerun_ms": round(_median_ms(samples["rerun"]), 4) if rerun else None,
        "total_ms": round(total_ms, 4),
        "fps": round(1e3 / total_ms, 1),
        "particle_substeps_per_s": round(model.num_points * substeps_per_frame / (step_ms * 1e-3)),
        "max_penetration_m": worst_penetration,
        "nan": not finite,
        "frames": frames,
        "warmup": warmup,
        "capped_springs": solver.constants.limited_springs,
        "threads": set_threads(None),
        "load_1min": load_average(),
    }
