"""``garment-sim replay BAG``: the node's frame loop on a recorded bag, offline, as fast as it goes.

The bag's /tf and /tf_static (``runtime.bag_io``: rosbag2, MCAP or SQLite3) go through the node's own
path: ``TFDecoder`` and ``ingest_batch`` (/tf), ``ingest`` (/tf_static), into a ``PoseBuffer``, and
``CharacterLoop`` dresses and simulates the character. Frames are on the bag's clock: frame ``k`` is
at ``t0 + k / rate_hz`` (``t0`` the first message's record time) and sees every message recorded
up to then, as the node would have; nothing depends on the wall clock (catching up after a hold is
not cut short by compute time), so the same bag gives the same garments, bit for bit.

Out: a Rerun recording (``--rrd``, by default next to the bag: ``BAG.rrd``) and, with
``--markers``, a bag of the MarkerArray topic next to the input (``BAG_markers``, the input's
storage), each message recorded at its frame's time and stamped with its pose's time, as the node
publishes them.
"""

from __future__ import annotations

import json
import logging
import math
import struct
import sys
import time
from pathlib import Path

from ..cloth.garments import GARMENT_NAMES

HELP = ("Replay a recorded rosbag2 (MCAP or SQLite3) of /tf and /tf_static through the node's frame loop, "
        "offline and as fast as possible on the bag's clock (deterministic), writing a Rerun recording and, "
        "with --markers, a bag of the garments' MarkerArray next to the input.")
MARKERS_TOPIC = "/garment_sim_node/markers"


def add_arguments(parser) -> None:
    parser.add_argument("bag", help="rosbag2 folder (or one .mcap / .db3 file) with /tf and /tf_static")
    parser.add_argument("--garments", default=None,
                        help=f"comma-separated, of: {', '.join(GARMENT_NAMES)} (default: the node's, pants)")
    parser.add_argument("--params-file", default="",
                        help="the node's parameter YAML (config/garment_sim.yaml): garments, rate, solver...")
    parser.add_argument("--node-name", default="/garment_sim_node",
                        help="the node's fully qualified name, to pick its section of --params-file")
    parser.add_argument("--rate", type=float, default=None, help="frame rate on the bag's clock, Hz (default: "
                        "the node's rate_hz, 60)")
    parser.add_argument("--frame-prefix", default=None, help="the character's /tf frame prefix (default: any)")
    parser.add_argument("--rrd", default="", help="the Rerun recording to write (default: BAG.rrd next to the bag)")
    parser.add_argument("--rerun-every-n", type=int, default=None,
                        help="log the 3D data of every n-th frame only (default: the node's rerun_every_n, 1)")
    parser.add_argument("--markers", action="store_true",
                        help=f"also write the garments' MarkerArray ({MARKERS_TOPIC}) to a bag BAG_markers")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")


def configuration(params_file: str = "", node_name: str = "/garment_sim_node", **given) -> dict:
    """The node's parameter values: the tables' defaults, the node's section of ``params_file``, then
    ``given`` (None: not given); each checked against its row (``ParameterError`` names what is allowed)."""
    from ..runtime.params_file import read_node_parameters
    from ..runtime.settings import check_value, default_values

    values = default_values()
    if params_file:
        values.update({name: check_value(name, value)
                       for name, value in read_node_parameters(params_file, node_name).items()})
    values.update({name: check_value(name, value) for name, value in given.items() if value is not None})
    return values


def next_to(bag: Path, suffix: str) -> Path:
    """A path beside the bag: ``walk_bag`` -> ``walk_bag<suffix>`` (a bag file loses its extension)."""
    stem = bag.name if bag.is_dir() else bag.stem
    return bag.parent / f"{stem}{suffix}"


class Replay:
    """One replay of ``bag`` with the node's parameter ``values`` (``configuration``): ``run()`` -> summary."""

    def __init__(self, bag: str | Path, values: dict, rrd: str | Path, markers_bag: str | Path | None = None):
        from ..body.pose_buffer import PoseBuffer
        from ..rerun_log import RerunLogger
        from ..runtime.bag_io import MARKER_ARRAY_TYPE, BagWriter, storage_of
        from ..runtime.character_loop import CharacterLoop
        from ..runtime.settings import solver_params
        from ..runtime.tf_input import TFDecoder

        self.bag = Path(bag)
        storage = storage_of(self.bag)
        self.values = v = values
        self.buffer = PoseBuffer(v["fixed_frame"], max_age_s=v["max_skeleton_age"],
                                 max_extrapolation_s=v["max_extrapolation"])
        # catch_up_wall_s: no wall-clock limit, the same bag must give the same garments; the quality
        # measured on every frame (the loop's default): offline, the node's quality_rate_hz does not apply
        self.loop = CharacterLoop(self.buffer, solver_params(v),
                                  v["garments"], v["resolution"], frame_prefix=v["frame_prefix"],
                                  root_frame=v["root_frame"], joint_map_file=v["joint_map_file"],
                                  body_file=v["body_file"], logger=logging.getLogger("garment_sim.replay"),
                                  catch_up_wall_s=math.inf, on_event=self._on_event)
        self.decoder = TFDecoder(v["frame_prefix"])
        self.markers = None
        if markers_bag is not None:  # first: it refuses an existing folder before anything is written
            self.markers = BagWriter(markers_bag, storage)
            self.markers.add_topic(MARKERS_TOPIC, MARKER_ARRAY_TYPE)
        self.rerun = RerunLogger("save", path=rrd, recording_name=f"replay of {self.bag.name}",
                                 every_n=v["rerun_every_n"])
        self.frame_time = 0.0
        self.undecodable = 0
        self.marker_messages = 0

    def _on_event(self, level: str, kind: str, message: str) -> None:
        self.rerun.log_event(self.frame_time, level, kind, message)

    def _ingest(self, messages: list[tuple[int, bool, bytes]]) -> None:
        """One frame's messages into the buffer: /tf as one decoded batch, /tf_static one by one."""
        from ..runtime.bag_io import decode_tf
        from ..runtime.tf_input import TransformBatch, ingest, ingest_batch

        batches = []
        for _, static, data in messages:
            try:
                if static:
                    ingest(self.buffer, decode_tf(data), self.values["frame_prefix"], static=True)
                else:
                    batches.append(self.decoder.decode(data))
            except (ValueError, IndexError, struct.error) as err:  # bytes that are no TFMessage
                self.undecodable += 1
                if self.undecodable == 1:
                    print(f"garment-sim replay: a {'/tf_static' if static else '/tf'} message could not be "
                          f"decoded (skipped, counted): {err}", file=sys.stderr)
        if batches:
            ingest_batch(self.buffer, TransformBatch.concatenate(batches), now_s=self.frame_time)

    def run(self) -> dict:
        """Every frame from the bag's first message to its last; returns the summary."""
        from ..rerun_log import frame_payload
        from ..runtime.bag_io import BagError, read_transforms
        from ..runtime.marker_cdr import serialize_marker_array
        from ..runtime.markers import frame_markers
        from ..runtime.tf_input import seconds_to_stamp

        v = self.values
        step_ns = 1e9 / v["rate_hz"]
        messages = read_transforms(self.bag)
        pending = next(messages, None)
        if pending is None:
            raise BagError(f"{str(self.bag)!r}: its /tf and /tf_static topics hold no message")
        start_ns = pending[0]
        frames = simulated = 0
        max_penetration = 0.0
        tic = time.perf_counter()
        try:
            while pending is not None:
                frame_ns = start_ns + round(frames * step_ns)
                arrived = []
                while pending is not None and pending[0] <= frame_ns:
                    arrived.append(pending)
                    pending = next(messages, None)
                self.frame_time = frame_ns * 1e-9
                self._ingest(arrived)
                frames += 1
                result = self.loop.frame(self.frame_time)
                if result is None:
                    continue
                simulated += 1
                max_penetration = max(max_penetration, result.penetration_m)
                payload = frame_payload(self.loop.character, result.pose)
                stamp = seconds_to_stamp(result.time_s)
                publish_tic = time.perf_counter()
                if self.markers is not None:
                    markers = frame_markers(payload, v["marker_namespace"], v["fixed_frame"], stamp,
                                            v["publish_volumes"], clear=result.dressed)
                    self.markers.write(MARKERS_TOPIC, frame_ns, serialize_marker_array(markers))
                    self.marker_messages += 1
                self.rerun.log_result(result, self.loop.character, payload, time.perf_counter() - publish_tic)
        finally:
            self.rerun.close()
            if self.markers is not None:
                self.markers.close()
        wall_s = time.perf_counter() - tic
        bag_s = (frames - 1) / v["rate_hz"] if frames else 0.0
        character = self.loop.character
        return {
            "bag": str(self.bag),
            "bag_seconds": bag_s,
            "frames": frames,
            "simulated_frames": simulated,
            "loop_counts": dict(sorted(self.loop.counts.items())),
            "rejected": dict(sorted(self.buffer.rejected.items())),
            "adjusted": dict(sorted(self.buffer.adjusted.items())),
            "joint_glitches": dict(sorted(self.buffer.glitches.items())),
            "undecodable": self.undecodable,
            "garments": [] if character is None else character.garment_names,
            "mass_points": self.loop.mass_points,
            "max_penetration_m": max_penetration,
            "wall_seconds": wall_s,
            "speed": bag_s / wall_s if wall_s > 0 else 0.0,
            "rrd": str(self.rerun.path),
            "markers_bag": None if self.markers is None else str(self.markers.path),
            "marker_messages": self.marker_messages,
        }


def run(args) -> int:
    from ..commands.simulate import parse_garments

    bag = Path(args.bag)
    values = configuration(args.params_file, args.node_name,
                           garments=parse_garments(args.garments) if args.garments else None,
                           rate_hz=args.rate, frame_prefix=args.frame_prefix, rerun_every_n=args.rerun_every_n)
    rrd = Path(args.rrd) if args.rrd else next_to(bag, ".rrd")
    summary = Replay(bag, values, rrd, next_to(bag, "_markers") if args.markers else None).run()
    if args.json:
        print(json.dumps(summary))
        return 0
    print(f"{summary['bag']}: {summary['bag_seconds']:.2f} s of the bag in {summary['frames']} frames at "
          f"{values['rate_hz']:g} Hz, replayed in {summary['wall_seconds']:.2f} s ({summary['speed']:.1f}x)")
    print(f"garments {', '.join(summary['garments']) or '(never dressed)'}: {summary['simulated_frames']} frames "
          f"simulated, {summary['mass_points']} mass points, max penetration "
          f"{summary['max_penetration_m'] * 1e3:.3f} mm")
    if summary["loop_counts"]:
        print("loop: " + ", ".join(f"{k} {n}" for k, n in summary["loop_counts"].items()))
    if summary["joint_glitches"]:
        print("joint glitches dropped: " + ", ".join(f"{k} {n}" for k, n in summary["joint_glitches"].items()))
    print(f"Rerun recording: {summary['rrd']}  (open it with: .venv/bin/rerun {summary['rrd']})")
    if summary["markers_bag"]:
        print(f"markers: {summary['marker_messages']} MarkerArray messages on {MARKERS_TOPIC} "
              f"in {summary['markers_bag']}")
    return 0
