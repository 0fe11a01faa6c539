"""Per-window frame statistics for the diagnostics status (ROS-free).

The node records every tick (its compute time) and every simulated frame (the garments'
``FrameReport``s, publish time, penetration); ``window()`` returns the figures since the last
call and starts a new window. Stage times are per frame, summed over the garments (Table 1's
columns: integration, length correction, collision handling, publishing). ``recoveries`` counts the
solver guard's events (a step restored or re-fitted, ``FrameReport.recovery``), the tries frames ran again
(``FrameReport.retries``, ``frame_retries``), the replays of frames with those before them (``replays``,
``replay_frames``) and the frames whose tries ``retry_budget`` stopped (``retries_cut``)
since the start.
The garments' quality figures (``garment_sim_ros.quality``: limb bones through the cloth, trouser
legs off, stretch p99 and max) and the penetration are the window's worst measured frame (the node
measures at ``quality_rate_hz``; ``quality_frames`` counts the measured frames), summed over the
garments for counts.
"""

from __future__ import annotations

import time
from collections import Counter
from typing import Sequence

import numpy as np

from ..cloth.solver import FrameReport
from ..quality import REPORT_SCALARS

_COUNTS = ("bones_through", "legs_off", "layer_crossings")  # add up over the garments; stretch takes the worst


class FrameStats:
    def __init__(self) -> None:
        self.lag_s = 0.0  # the garments' lag behind the skeleton at the last frame (the largest)
        self.total_frames = 0
        # solver guard events since start, by FrameReport.recovery, and garment frames carried after them
        self.recoveries: Counter[str] = Counter()
        self._start()

    def _start(self) -> None:
        self._window_start = time.monotonic()
        self._ticks = 0
        self._tick_s = 0.0
        self._frames = 0
        self._stepped = 0
        self._substeps = 0
        self._stages = {"integration": 0.0, "correction": 0.0, "collision": 0.0, "publish": 0.0}
        self._penetration = 0.0
        self._stretch = 0.0
        self._quality = {name: 0.0 for name, _, _ in REPORT_SCALARS if name != "depth_mm"}  # worst in the window
        self._bones_frames = 0  # measured frames with a limb bone through a garment
        self._measured = 0  # frames whose quality was measured
        self._hits = [0, 0]
        self._body_s = 0.0
        self._simulated_s = 0.0
        self._input_lags: list[float] = []
        self._backlog = 0

    def record_input(self, lag_s: float) -> None:
        """A /tf message absorbed ``lag_s`` after its newest stamp (receive time - stamp)."""
        self._input_lags.append(lag_s)

    def input_rate(self) -> float:
        """/tf messages absorbed per second in the current window."""
        return len(self._input_lags) / max(time.monotonic() - self._window_start, 1e-9)

    def record_drain(self, messages: int) -> None:
        """One frame's drain of /tf took ``messages`` (the backlog since the last frame)."""
        self._backlog = max(self._backlog, messages)

    def record_tick(self, compute_s: float) -> None:
        self._ticks += 1
        self._tick_s += compute_s

    def record_frame(self, reports: Sequence[FrameReport], frame_s: float, penetration_m: float,
                     measured: bool = True, catch_up_recoveries: Sequence[str] = ()) -> None:
        """A simulated frame: the garments' reports (none for a dressing frame), the body time it
        covered, the deepest penetration after it; ``measured``: its quality figures and penetration were
        measured (``FrameResult.measured``), else they are not this frame's and are left out;
        ``catch_up_recoveries``: the guard's events in the frame's catch-up pieces before the last
        (``FrameResult.catch_up_recoveries``), counted with the reports'."""
        self._frames += 1
        self.total_frames += 1
        if measured:
            self._measured += 1
            self._penetration = max(self._penetration, penetration_m)
        if not reports:  # the dressing frame
            return
        self._stepped += 1
        self.recoveries.update(r.recovery for r in reports if r.recovery)
        self.recoveries.update(catch_up_recoveries)
        self.recoveries.update(["carried"] * sum(r.carried for r in reports))  # garment frames carried after one
        self.recoveries.update(["retried"] * sum(r.retries for r in reports))  # tries run again (``frame_retries``)
        self.recoveries.update(["replayed"] * sum(r.replays for r in reports))  # replays (``replay_frames``)
        self.recoveries.update(["retries_cut"] * sum(r.retries_cut for r in reports))  # stopped by ``retry_budget``
        self._substeps += max(r.substeps for r in reports)
        self._stages["integration"] += sum(r.integration_s for r in reports)
        self._stages["correction"] += sum(r.correction_s for r in reports)
        self._stages["collision"] += sum(r.collision_s for r in reports)
        self._stretch = max(self._stretch, max(r.max_stretch for r in reports))
        self.lag_s = max(r.lag_s for r in reports)
        self._body_s += frame_s
        self._simulated_s += min(r.simulated_s for r in reports)
        self._hits = [sum(r.static_hits for r in reports), sum(r.dynamic_hits for r in reports)]
        if not measured:
            return
        for name, field, _ in REPORT_SCALARS:
            if name in self._quality:
                values = [getattr(r, field) for r in reports]
                frame = sum(values) if name in _COUNTS else max(values)
                self._quality[name] = max(self._quality[name], frame)
        self._bones_frames += any(r.bones_through for r in reports)

    def record_publish(self, seconds: float) -> None:
        self._stages["publish"] += seconds

    def window(self) -> dict[str, float]:
        """Figures since the last call: fps (simulated frames per second of wall time), mean stage
        and tick times in ms, mean substeps, the window's worst penetration and stretch, and
        ``lag_fraction``, the share of the body's time the garments did not simulate in the window
        (past ``max_substeps``); ``lag_s`` is the garments' total lag since they were dressed; the
        quality figures (``bones_through``, ``legs_off``, ``structural_stretch_p99``... as in
        ``quality.REPORT_SCALARS``) are the window's worst measured frame, ``bones_through_frames`` counts
        the window's measured frames with a limb bone through a garment, ``quality_frames`` the frames
        measured; ``input_hz``, the /tf messages of the character absorbed per second,
        ``input_lag_p50_ms`` / ``_p99_ms``, their receive time minus stamp, and ``input_backlog``,
        the most /tf messages one frame found waiting."""
        elapsed = max(time.monotonic() - self._window_start, 1e-9)
        per_frame = max(self._frames, 1)
        per_step = max(self._stepped, 1)
        figures = {
            "fps": self._frames / elapsed,
            "ticks": float(self._ticks),
            "frames": float(self._frames),
            "substeps": self._substeps / per_step,
            "lag_s": self.lag_s,
            "lag_fraction": 1.0 - self._simulated_s / self._body_s if self._body_s > 0.0 else 0.0,
            "tick_ms": 1e3 * self._tick_s / max(self._ticks, 1),
            **{f"{stage}_ms": 1e3 * total / (per_frame if stage == "publish" else per_step)
               for stage, total in self._stages.items()},
            "max_penetration_mm": 1e3 * self._penetration,
            "max_stretch": self._stretch,
            **self._quality,
            "bones_through_frames": float(self._bones_frames),
            "quality_frames": float(self._measured),
            "static_hits": float(self._hits[0]),
            "dynamic_hits": float(self._hits[1]),
            "input_hz": len(self._input_lags) / elapsed,
            "input_backlog": float(self._backlog),
            **dict(zip(("input_lag_p50_ms", "input_lag_p99_ms"),
                       (1e3 * np.percentile(self._input_lags, (50, 99)) if self._input_lags else (0.0, 0.0)))),
        }
        self._start()
        return figures
