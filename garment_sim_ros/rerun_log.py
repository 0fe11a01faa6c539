"""Rerun logging of a dressed character, frame by frame (ROS-free).

``RerunLogger`` owns its own ``rerun.RecordingStream`` (never the global one), so two loggers in
one process (two characters, a test beside a node) write separate recordings. Entity layout:

- ``world``: view coordinates, right-handed z up (REP-103), static;
- ``world/character``: a ``Transform3D`` under the pelvis (its x, y; z = 0, no rotation), every
  frame: the default 3D view's origin, so the view follows the character wherever it walks;
- ``world/garments/<name>``: ``Mesh3D``; triangles and the garment's colour static (re-sent when
  the triangles change), vertex positions and normals per frame (the viewer lights the mesh);
- ``world/body/volumes``: ``Ellipsoids3D`` (see ``volume_ellipsoids`` for the shapes shown);
- ``world/body/skeleton``: ``LineStrips3D``, one two-point strip per bone;
- ``frame/<figure>``: ``Scalars``: ``fps`` (simulated frames per wall second), ``lag_ms`` (the
  garments behind the skeleton), ``substeps`` (of the kept try), ``retries`` (the frame run again with twice the
  substeps, ``frame_retries``), ``replays`` (the frame run again with the frames before it, ``replay_frames``),
  ``penetration_mm`` (deepest garment point in a volume;
  on the frames the quality meters measured, ``FrameResult.measured``: the node's ``quality_rate_hz``);
- ``timings/<stage>``: ``Scalars``, milliseconds;
- ``quality/<garment>/<figure>``: ``Scalars``, how well each garment stays on (``quality.report_scalars``:
  ``depth_mm``, ``bones_through``, ``legs_off``, stretch p99 and max on the measured frames, ``guard``
  every frame);
- ``input/<figure>``: ``Scalars``, the /tf input (``lag_ms``, ``backlog``);
- ``events``: ``TextLog``: dressing, teleports, re-dresses, holds, guard recoveries, parameter changes;

all on the ``sim_time`` timeline as timestamps (the stamp of the pose a frame was simulated on, in
the node's clock), with a blueprint: the 3D view that follows the character above the events,
beside the plots. ``every_n`` > 1 logs the 3D data (meshes, volumes, skeleton) of every n-th frame
only: the recording shrinks about n times; scalars and events are logged every frame.

``frame_payload(character, pose)`` builds ``log_frame``'s arguments from a ``DressedCharacter``
and a ``SkeletonPose``; the node, the demo, ``garment-sim replay`` and ``garment-sim snapshot`` share
it; ``log_result`` logs a ``CharacterLoop`` frame (the node and the replay).
"""

from __future__ import annotations

import math
import re
import time
import uuid
from collections import deque
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from .body.aiming import volume_poses
from .collision.volumes import CAPSULE, ELLIPSOID, VolumeSet
from .quality import report_scalars
from .shading import BODY_RGB, DEFAULT_LIGHT_DIR, SKELETON_RGB, garment_color, shade
from .transforms import quat_rotate

SINKS = ("off", "save", "connect", "serve")
TIMELINE = "sim_time"
CHARACTER_ENTITY = "world/character"
EVENTS_ENTITY = "events"
FPS_WINDOW_S = 1.0  # fps: simulated frames in the last second of wall time
SAVE_FLUSH_TICK_S = 1.0  # a saved recording's chunks: at most a second...
SAVE_FLUSH_BYTES = 2 << 20  # ...or 2 MiB of data (Rerun's object-store target chunk size)
DEFAULT_CONNECT_URL = "rerun+http://127.0.0.1:9876/proxy"
_URL_SCHEMES = ("rerun://", "rerun+http://", "rerun+https://")
_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")  # one entity-path part, no escaping needed
SKELETON_LINE_RADIUS_M = 0.006
_TEXT_LOG_LEVELS = {"info": "INFO", "warning": "WARN", "error": "ERROR"}


class RerunLogger:
    """Log garments, body volumes, the skeleton and stage timings to Rerun.

    ``sink``:
      - ``"off"``: nothing is created or written; ``log_frame`` returns at once (``enabled`` is False);
      - ``"save"``: stream to the ``.rrd`` file ``path`` (its folder is created);
      - ``"connect"``: stream to a running viewer at ``url`` (default ``rerun+http://127.0.0.1:9876/proxy``);
      - ``"serve"``: serve the stream over gRPC on ``port`` (default 9876) for viewers to connect to.
        Opt-in: Rerun 0.41 binds the server to 0.0.0.0, so the stream is exposed on EVERY network
        interface of the machine, to anyone who can reach the port.
    ``path`` is read only by ``save``, ``url`` by ``connect``, ``port`` by ``serve``. ``every_n``
    (frames, >= 1): the 3D data of every n-th ``log_frame`` only (it can change at any time).
    """

    def __init__(self, sink: str = "off", path: str | Path | None = None, url: str | None = None,
                 application_id: str = "garment_sim", recording_name: str = "garment_sim",
                 port: int | None = None, every_n: int = 1):
        if sink not in SINKS:
            raise ValueError(f"RerunLogger: unknown sink {sink!r}; allowed: {', '.join(SINKS)}")
        for label, value in (("application_id", application_id), ("recording_name", recording_name)):
            if not isinstance(value, str) or not value.strip():
                raise ValueError(f"RerunLogger: {label} must be a non-empty string, got {value!r}")
        self.sink = sink
        self.path: Path | None = None
        self.url: str | None = None
        self.every_n = every_n
        self._stream = None
        self._static: dict[str, np.ndarray] = {}  # what each entity's static part was logged with
        self._frames = 0
        self._frame_walls: deque[float] = deque()  # wall times of the last second's log_result calls
        if sink == "off":
            return
        if sink == "save":
            if path is None or not str(path).strip():
                raise ValueError("RerunLogger: sink 'save' needs path= (the .rrd file to write)")
            self.path = Path(path)
            if self.path.suffix != ".rrd":
                raise ValueError(f"RerunLogger: path {str(path)!r} must end in .rrd")
            if self.path.is_dir():
                raise ValueError(f"RerunLogger: path {str(path)!r} is a directory; give a .rrd file name")
            self.path.parent.mkdir(parents=True, exist_ok=True)
        elif sink == "connect":
            self.url = DEFAULT_CONNECT_URL if url is None else url
            if not (isinstance(self.url, str) and self.url.startswith(_URL_SCHEMES) and self.url.endswith("/proxy")):
                raise ValueError(f"RerunLogger: url {url!r} is not a Rerun gRPC address; expected "
                                 f"{' or '.join(s + 'HOST:PORT/proxy' for s in _URL_SCHEMES)}")
        elif port is not None and (isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535):
            raise ValueError(f"RerunLogger: port must be an integer in [1, 65535], got {port!r}")

        import rerun as rr

        self._rr = rr
        # A file is read after the run: batch a second's data (or 2 MiB) per chunk, not the live default
        # of 8 ms: ~25x fewer chunks, a seventh less schema overhead, what `rerun rrd optimize` would do.
        batching = rr.ChunkBatcherConfig(flush_tick=SAVE_FLUSH_TICK_S, flush_num_bytes=SAVE_FLUSH_BYTES) \
            if sink == "save" else None
        self._stream = rr.RecordingStream(application_id, recording_id=uuid.uuid4(), batcher_config=batching)
        blueprint = _blueprint()
        if sink == "save":
            self._stream.save(self.path, default_blueprint=blueprint)
        elif sink == "connect":
            self._stream.connect_grpc(self.url, default_blueprint=blueprint)
        else:
            self.url = self._stream.serve_grpc(grpc_port=port, default_blueprint=blueprint)
        self._stream.send_recording_name(recording_name)
        for entity in ("world", CHARACTER_ENTITY):  # the up axis of both views' origins
            self._stream.log(entity, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    @property
    def enabled(self) -> bool:
        return self._stream is not None

    @property
    def every_n(self) -> int:
        return self._every_n

    @every_n.setter
    def every_n(self, value: int) -> None:
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"RerunLogger: every_n must be an integer >= 1, got {value!r}")
        self._every_n = value

    def log_frame(self, time_s: float, garments: Sequence[tuple] = (), volumes: tuple | None = None,
                  skeleton_segments: np.ndarray | None = None, timings_ms: Mapping[str, float] | None = None,
                  quality: Mapping[str, Mapping[str, float]] | None = None,
                  inputs: Mapping[str, float] | None = None, frame: Mapping[str, float] | None = None,
                  pelvis: np.ndarray | None = None) -> None:
        """Log one frame at ``time_s`` (s, the node's clock) on the ``sim_time`` timeline.

        ``garments``: ``(name, positions (N,3), normals (N,3), triangles (T,3) int, colors (N,3) uint8)``
        each (``colors``, shaded for the markers, are checked but not logged: the viewer lights the
        mesh in the garment's colour, ``shading.garment_color``); ``volumes``: ``(centers (V,3),
        rotations (V,4) xyzw, half_sizes (V,3))``; ``skeleton_segments``: ``(S, 2, 3)``;
        ``timings_ms``: ``{stage: milliseconds}``; ``quality``: ``{garment: {figure: value}}``
        (``quality.report_scalars``); ``inputs``: the /tf input at this frame, ``{figure: value}``
        (the node's ``lag_ms``, ms, and ``backlog``, messages); ``frame``: ``{figure: value}`` under
        ``frame/`` (``log_result``'s fps, lag, substeps, penetration); ``pelvis``: (3,) m, where
        ``world/character`` (the 3D view's origin) goes.
        """
        if self._stream is None:
            return
        rr, stream = self._rr, self._stream
        if isinstance(time_s, bool) or not isinstance(time_s, (int, float)) or not math.isfinite(time_s):
            raise ValueError(f"log_frame: time_s must be a finite number of seconds, got {time_s!r}")
        checked = [_check_garment(g) for g in garments]
        if volumes is not None:
            volumes = _check_volumes(volumes)
        if skeleton_segments is not None:
            skeleton_segments = _check_array("skeleton_segments", skeleton_segments, (None, 2, 3), float)
        if pelvis is not None:
            pelvis = _check_array("pelvis", pelvis, (3,), float)
        timings = _check_timings(timings_ms or {})
        figures = {_check_name("garment name", name): _check_timings(values, "quality figure", "")
                   for name, values in (quality or {}).items()}
        input_figures = _check_timings(inputs or {}, "input figure", "")
        frame_figures = _check_timings(frame or {}, "frame figure", "")

        stream.set_time(TIMELINE, timestamp=float(time_s))
        if pelvis is not None:  # on the floor under the pelvis: the view's grid stays the floor
            stream.log(CHARACTER_ENTITY, rr.Transform3D(translation=[pelvis[0], pelvis[1], 0.0]))
        if self._frames % self._every_n == 0:
            for name, positions, normals, triangles, _colors in checked:
                entity = f"world/garments/{name}"
                self._log_static(entity, triangles, lambda: rr.Mesh3D.from_fields(
                    triangle_indices=triangles.astype(np.uint32), albedo_factor=garment_color(name)))
                stream.log(entity, rr.Mesh3D.from_fields(vertex_positions=positions, vertex_normals=normals))
            if volumes is not None:
                centers, rotations, half_sizes = volumes
                self._log_static("world/body/volumes", half_sizes, lambda: rr.Ellipsoids3D.from_fields(
                    half_sizes=half_sizes, colors=[BODY_RGB]))
                stream.log("world/body/volumes", rr.Ellipsoids3D.from_fields(centers=centers, quaternions=rotations))
            if skeleton_segments is not None:
                self._log_static("world/body/skeleton", np.zeros(0), lambda: rr.LineStrips3D.from_fields(
                    radii=SKELETON_LINE_RADIUS_M, colors=[SKELETON_RGB]))
                stream.log("world/body/skeleton", rr.LineStrips3D.from_fields(strips=skeleton_segments))
        self._frames += 1
        for group, values in (("timings", timings), ("input", input_figures), ("frame", frame_figures)):
            for figure, value in values.items():
                stream.log(f"{group}/{figure}", rr.Scalars(value))
        for name, values in figures.items():
            for figure, value in values.items():
                stream.log(f"quality/{name}/{figure}", rr.Scalars(value))

    def _log_static(self, entity: str, key: np.ndarray, archetype) -> None:
        """Log ``archetype()`` as ``entity``'s static data the first time and whenever ``key`` changes
        (a garment's triangles, the volumes' sizes after a new body), never again otherwise."""
        known = self._static.get(entity)
        if known is None or known.shape != key.shape or not np.array_equal(known, key):
            self._stream.log(entity, archetype(), static=True)
            self._static[entity] = np.array(key, copy=True)

    def log_event(self, time_s: float, level: str, kind: str, message: str) -> None:
        """A ``TextLog`` entry on ``events`` at ``time_s``: ``level`` ``info``, ``warning`` or ``error``;
        ``kind`` a short name (``teleported``, ``guard``, ``parameters``...) shown before the message."""
        if self._stream is None:
            return
        if level not in _TEXT_LOG_LEVELS:
            raise ValueError(f"log_event: level {level!r}; allowed: {', '.join(_TEXT_LOG_LEVELS)}")
        if isinstance(time_s, bool) or not isinstance(time_s, (int, float)) or not math.isfinite(time_s):
            raise ValueError(f"log_event: time_s must be a finite number of seconds, got {time_s!r}")
        self._stream.set_time(TIMELINE, timestamp=float(time_s))
        self._stream.log(EVENTS_ENTITY, self._rr.TextLog(f"{kind}: {message}", level=_TEXT_LOG_LEVELS[level]))

    def log_result(self, result, character, payload: Mapping, publish_s: float = 0.0,
                   inputs: Mapping[str, float] | None = None) -> None:
        """Log a ``CharacterLoop`` frame (``FrameResult``) of ``character`` (``DressedCharacter``) with its
        ``frame_payload``: at the time of the pose it was simulated on, the stage timings, each
        garment's quality, the ``frame/`` figures, and the guard's recoveries as events.
        ``publish_s``: the markers' publish time, s; ``inputs``: as ``log_frame``'s."""
        if self._stream is None:
            return
        now = time.perf_counter()
        self._frame_walls.append(now)
        while now - self._frame_walls[0] > FPS_WINDOW_S:
            self._frame_walls.popleft()
        span = now - self._frame_walls[0]
        reports = result.reports
        # the quality meters' figures only on the frames they measured (the node's quality_rate_hz)
        frame = {"penetration_mm": 1e3 * result.penetration_m} if result.measured else {}
        if span > 0.0:
            frame["fps"] = (len(self._frame_walls) - 1) / span
        timings, quality = {}, {}
        if reports:  # a dressing frame has none
            frame["lag_ms"] = 1e3 * max(r.lag_s for r in reports)
            frame["substeps"] = float(max(r.substeps for r in reports))
            frame["retries"] = float(max(r.retries for r in reports))
            frame["replays"] = float(max(r.replays for r in reports))
            timings = {"integration": sum(r.integration_s for r in reports),
                       "correction": sum(r.correction_s for r in reports),
                       "collision": sum(r.collision_s for r in reports)}
            quality = {solver.model.name: report_scalars(report) if result.measured
                       else {"guard": float(bool(report.recovery))}  # the solver's own, every frame
                       for solver, report in zip(character.solvers, reports)}
        timings["publish"] = publish_s
        time_s = result.time_s
        self.log_frame(time_s, timings_ms={k: 1e3 * s for k, s in timings.items()}, quality=quality,
                       inputs=inputs, frame=frame, **payload)
        for solver, report in zip(character.solvers, reports):
            if report.recovery:
                self.log_event(time_s, "warning", "guard", f"{solver.model.name}: the step went bad, {report.recovery}")

    def close(self) -> None:
        """Flush everything logged and end the stream (a saved file is complete after this)."""
        if self._stream is not None:
            self._stream.flush()
            self._stream.disconnect()
            self._stream = None

    def __enter__(self) -> "RerunLogger":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _blueprint():
    """The 3D view's origin is ``world/character`` (under the pelvis) and it shows all of ``world``:
    the character stays in the middle of the view at every moment, the world passes by."""
    import rerun.blueprint as rrb

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial3DView(origin=CHARACTER_ENTITY, contents="/world/**",
                                  name="dressed character (the view follows the pelvis)"),
                rrb.TextLogView(origin=EVENTS_ENTITY, name="events"),
                row_shares=[4, 1],
            ),
            rrb.Vertical(
                rrb.TimeSeriesView(origin="frame", contents=["/frame/fps", "/frame/substeps", "/frame/retries",
                                                             "/frame/replays"],
                                   name="frames per second, substeps, retries and replays per frame"),
                rrb.TimeSeriesView(origin="frame", contents=["/frame/lag_ms", "/frame/penetration_mm"],
                                   name="garment lag [ms], penetration [mm]"),
                rrb.TimeSeriesView(origin="quality", name="garment quality"),
                rrb.TimeSeriesView(origin="timings", name="stage timings [ms]"),
                rrb.TimeSeriesView(origin="input", name="/tf input: lag [ms], backlog"),
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )


# ---------------------------------------------------------------------------------- validation
def _check_array(label: str, value, shape: tuple, dtype) -> np.ndarray:
    """``value`` as an array of ``shape`` (None: any length) with finite entries."""
    try:
        array = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError):
        raise ValueError(f"log_frame: {label} must be a numeric array of shape {_shape_text(shape)}") from None
    if array.ndim != len(shape) or any(want is not None and got != want for got, want in zip(array.shape, shape)):
        raise ValueError(f"log_frame: {label} must have shape {_shape_text(shape)}, got {array.shape}")
    if array.dtype.kind == "f" and not np.all(np.isfinite(array)):
        raise ValueError(f"log_frame: {label} has non-finite values")
    return array


def _shape_text(shape: tuple) -> str:
    return "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"


def _check_name(label: str, name) -> str:
    if not isinstance(name, str) or not _NAME.match(name):
        raise ValueError(f"log_frame: {label} {name!r} must be a non-empty name of letters, digits, '_', '.', '-'")
    return name


def _check_garment(garment) -> tuple:
    if not isinstance(garment, (tuple, list)) or len(garment) != 5:
        raise ValueError("log_frame: each garment must be (name, positions, normals, triangles, colors)")
    name, positions, normals, triangles, colors = garment
    name = _check_name("garment name", name)
    positions = _check_array(f"garment {name!r} positions", positions, (None, 3), np.float32)
    count = len(positions)
    normals = _check_array(f"garment {name!r} normals", normals, (count, 3), np.float32)
    triangles = np.asarray(triangles)
    if triangles.ndim != 2 or triangles.shape[1] != 3 or triangles.dtype.kind not in "iu":
        raise ValueError(f"log_frame: garment {name!r} triangles must be an integer array of shape (T, 3), "
                         f"got {triangles.dtype} {triangles.shape}")
    if triangles.size and (triangles.min() < 0 or triangles.max() >= count):
        raise ValueError(f"log_frame: garment {name!r} triangles index vertices {triangles.min()}..{triangles.max()}, "
                         f"the garment has {count}")
    colors = np.asarray(colors)
    if colors.dtype != np.uint8 or colors.shape not in ((count, 3), (count, 4)):
        raise ValueError(f"log_frame: garment {name!r} colors must be uint8 of shape ({count}, 3) or ({count}, 4), "
                         f"got {colors.dtype} {colors.shape}")
    return name, positions, normals, triangles, colors


def _check_volumes(volumes) -> tuple:
    if not isinstance(volumes, (tuple, list)) or len(volumes) != 3:
        raise ValueError("log_frame: volumes must be (centers (V,3), rotations (V,4), half_sizes (V,3))")
    centers = _check_array("volume centers", volumes[0], (None, 3), np.float32)
    rotations = _check_array("volume rotations", volumes[1], (len(centers), 4), np.float32)
    half_sizes = _check_array("volume half_sizes", volumes[2], (len(centers), 3), np.float32)
    if np.any(half_sizes <= 0.0):
        raise ValueError("log_frame: volume half_sizes must be positive")
    return centers, rotations, half_sizes


def _check_timings(timings: Mapping[str, float], label: str = "timing", unit: str = " of ms") -> dict[str, float]:
    """Finite scalars by name: ``timings_ms`` (stage -> ms) or one garment's quality figures."""
    if not isinstance(timings, Mapping):
        raise ValueError(f"log_frame: {label}s must be a mapping name -> number, got {type(timings).__name__}")
    checked = {}
    for stage, value in timings.items():
        _check_name(label, stage)
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
                or not math.isfinite(value):
            raise ValueError(f"log_frame: {label} {stage!r} must be a finite number{unit}, got {value!r}")
        checked[stage] = float(value)
    return checked


# ---------------------------------------------------------------------------------- payload
def skeleton_segments(pose) -> np.ndarray:
    """Bones of a ``SkeletonPose`` as segments (S, 2, 3): parent joint -> child joint, world frame."""
    parents = np.asarray(pose.skeleton.parents)
    children = np.flatnonzero(parents >= 0)
    return np.stack([pose.positions[parents[children]], pose.positions[children]], axis=1)


def volume_ellipsoids(volumes: VolumeSet, pose) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every volume as an ellipsoid ``(centers (V,3), rotations (V,4) xyzw, half_sizes (V,3))`` in the world.

    Sphere: ``(r, r, r)``. Ellipsoid: ``a_x, a_y`` and, along z, the cut range only: an ellipsoid
    centred in the kept range ``[cut0, cut1]`` (clamped to ``+-a_z``) with half length half of it,
    so the shown extent is what collides (ends rounded where the volume is cut flat). Capsule: the
    ellipsoid with the capsule's extent on each local axis, ``(r_max, r_max, half_length + r_max)``
    (thinner than the capsule towards its ends).
    """
    centers, rotations = volume_poses(volumes, pose)
    radii = volumes.radii
    half_sizes = radii.copy()
    shift = np.zeros(len(volumes))
    ellipsoid = volumes.kinds == ELLIPSOID
    low = np.maximum(volumes.cuts[:, 0], -radii[:, 2])
    high = np.minimum(volumes.cuts[:, 1], radii[:, 2])
    half_sizes[ellipsoid, 2] = 0.5 * (high - low)[ellipsoid]
    shift[ellipsoid] = 0.5 * (high + low)[ellipsoid]
    capsule = volumes.kinds == CAPSULE
    widest = np.maximum(radii[:, 0], radii[:, 1])
    half_sizes[capsule] = np.column_stack([widest, widest, radii[:, 2] + widest])[capsule]
    centers = centers + quat_rotate(rotations, np.column_stack([np.zeros((len(shift), 2)), shift]))
    return centers, rotations, half_sizes


def garment_meshes(character, light_dir=DEFAULT_LIGHT_DIR) -> list[tuple]:
    """``(name, positions, normals, triangles, colors)`` of every garment of a ``DressedCharacter``
    at its last frame, world frame, colours shaded from the normals."""
    from .cloth.kernels import vertex_normals

    meshes = []
    for solver, positions in zip(character.solvers, character.world_positions()):
        triangles = solver.model.triangles
        normals = np.empty_like(positions)
        vertex_normals(positions, triangles, normals)
        name = solver.model.name
        meshes.append((name, positions, normals, triangles, shade(normals, garment_color(name), light_dir)))
    return meshes


def frame_payload(character, pose, light_dir=DEFAULT_LIGHT_DIR) -> dict:
    """``log_frame``'s arguments (``garments``, ``volumes``, ``skeleton_segments``, ``pelvis``) for a
    ``DressedCharacter`` at its last frame and the ``SkeletonPose`` it was stepped to."""
    return {
        "garments": garment_meshes(character, light_dir),
        "volumes": volume_ellipsoids(character.body.volumes, pose),
        "skeleton_segments": skeleton_segments(pose),
        "pelvis": pose.frame(character.joint_map["pelvis"])[0],
    }
