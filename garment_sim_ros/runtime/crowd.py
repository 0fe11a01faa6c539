"""Several characters in one process (ROS-free): one ``Member`` per frame prefix, each with its own
``PoseBuffer``, ``CharacterLoop``, frame figures and input counts.

- /tf: every message is decoded once and each transform routed to its character
  (``tf_input.TFDecoder`` over all the prefixes; ``route_tf``). Prefixes must not overlap
  (``check_prefixes``): a frame is one character's.
- markers: one MarkerArray per frame holds every character's garments and volumes, each character
  under ``<marker_namespace>/<prefix without its '/'>`` (``<ns>/alice/one_piece``, ``<ns>/alice/volumes``)
  when there are several, under ``<marker_namespace>`` as before for one (``crowd_markers``).
- the characters' garments go through the solver one after another: the kernels hold the GIL (no
  ``nogil``), so Python threads over characters would not overlap, and the collision kernels already
  use both cores (``garment-sim crowd`` measures the cost per character). Tried: the fused frame
  ``nogil`` and the characters' frames on a thread per core: at load 6.4 on the 2 cores, 2-10 % slower
  and 3-8 % more CPU per tick (docs/benchmarks.md, "The crowd's tick").

Beyond one process the answer is ROS: one node per group of characters, any number of machines on
the same DDS domain (README, "A crowd").
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

from ..body.pose_buffer import PoseBuffer
from ..params import ParameterError, SolverParams
from ..rerun_log import frame_payload
from .character_loop import CharacterLoop, FrameResult
from .frame_stats import FrameStats
from .marker_cdr import MarkerData
from .markers import delete_all, frame_markers
from .settings import garment_folders
from .tf_input import IngestResult, TFDecoder, TransformBatch, ingest_batch, seconds_to_stamp


def character_prefixes(frame_prefix: str, frame_prefixes: Sequence[str]) -> list[str]:
    """The characters of a node: ``frame_prefixes`` when set (anything but its default ``[""]``), else
    the one character of ``frame_prefix``; ``ParameterError`` for overlapping prefixes."""
    prefixes = list(frame_prefixes) if list(frame_prefixes) != [""] else [frame_prefix]
    return check_prefixes(prefixes)


def check_prefixes(prefixes: Sequence[str]) -> list[str]:
    """``prefixes``, or ``ParameterError`` when one starts another (a frame would be two characters')."""
    for a in prefixes:
        for b in prefixes:
            if a is not b and b.startswith(a):
                raise ParameterError(f"frame_prefixes: {a!r} is the start of {b!r}: the frames of {b!r} would "
                                     f"be two characters'; allowed: prefixes none of which starts another "
                                     "(e.g. alice/, bob/)")
    return list(prefixes)


def character_namespace(marker_namespace: str, prefix: str, crowd: bool) -> str:
    """The markers' namespace of the character of ``prefix``: its own below ``marker_namespace`` in a crowd."""
    name = prefix.strip("/")
    return f"{marker_namespace}/{name}" if crowd and name else marker_namespace


@dataclass(eq=False)  # a character is itself: compared by identity
class Member:
    """One character of a crowd and what the node keeps of it."""

    prefix: str
    buffer: PoseBuffer
    loop: CharacterLoop
    stats: FrameStats = field(default_factory=FrameStats)
    input_counts: Counter = field(default_factory=Counter)  # transforms stored / of other characters / refused
    held: tuple[dict, tuple[int, int]] | None = None  # the last simulated frame's payload and stamp
    markers: list[MarkerData] = field(default_factory=list)  # ...as markers (the held frame's)

    def count_input(self, result: IngestResult, count_empty: bool = True) -> str:
        """Count an ingest's transforms; the first refusal's reason ("" when none)."""
        self.input_counts["stored"] += result.stored
        self.input_counts["other_character"] += result.other_character
        self.input_counts["refused"] += result.refused
        if count_empty and not (result.stored or result.other_character or result.refused):
            self.input_counts["empty_messages"] += 1  # nothing to do; counted so a silent publisher shows
        return result.first_refusal if result.refused else ""

    def hold(self, result: FrameResult, namespace: str, values: dict[str, Any]) -> None:
        """Keep a simulated frame: its payload, stamp (the pose's time) and markers."""
        self.held = (frame_payload(self.loop.character, result.pose), seconds_to_stamp(result.time_s))
        self.restyle(namespace, values)

    def restyle(self, namespace: str, values: dict[str, Any]) -> None:
        """The held frame's markers again (the namespace or the volumes' switch changed)."""
        if self.held is not None:
            payload, stamp = self.held
            self.markers = frame_markers(payload, namespace, values["fixed_frame"], stamp, values["publish_volumes"])


def make_members(prefixes: Sequence[str], values: dict[str, Any], params: SolverParams, logger=None,
                 on_event: Callable[[str, str, str], None] | None = None) -> list[Member]:
    """A ``Member`` per prefix, configured from the node's parameter ``values``; in a crowd each
    character logs as a child logger named after its prefix and its events start with the prefix, and
    the k-th of n measures its quality k/n of the meters' period after the first (``quality_phase``): the
    meters' cost spread over the ticks."""
    crowd = len(prefixes) > 1
    members = []
    for index, prefix in enumerate(prefixes):
        buffer = PoseBuffer(values["fixed_frame"], max_age_s=values["max_skeleton_age"],
                            max_extrapolation_s=values["max_extrapolation"])
        name = prefix.strip("/")
        events = on_event
        if crowd and on_event is not None:
            def events(level, kind, message, name=name):
                on_event(level, kind, f"{name}: {message}")
        loop = CharacterLoop(buffer, params, values["garments"], values["resolution"], frame_prefix=prefix,
                             root_frame=values["root_frame"] if not crowd else "",
                             joint_map_file=values["joint_map_file"], body_file=values["body_file"],
                             logger=logger.get_child(name) if crowd and logger is not None and name else logger,
                             on_event=events, garment_path=garment_folders(values["garment_path"]),
                             quality_rate_hz=values["quality_rate_hz"], quality_phase=index / len(prefixes))
        members.append(Member(prefix, buffer, loop))
    return members


def route_tf(decoder: TFDecoder, members: Sequence[Member], messages: Sequence[bytes],
             now_s: float | None) -> tuple[list[str], list[str], list[float]]:
    """Every /tf message decoded once, each transform into its character's buffer (all of a frame's
    messages in one batch per character). Returns the decoding errors, the buffers' first refusals and
    each stamped message's lag behind ``now_s`` (receive time - newest stamp; none without a clock)."""
    per_member: list[list[TransformBatch]] = [[] for _ in members]
    errors, lags = [], []
    for data in messages:
        try:
            batches = decoder.decode_characters(data)
        except ValueError as err:
            errors.append(str(err))
            continue
        stamped = [b.stamps.max() for b in batches if len(b.stamps)]
        if stamped and now_s is not None:
            lags.append(now_s - float(max(stamped)))
        if not stamped and not batches[0].other_character:
            members[0].input_counts["empty_messages"] += 1  # nothing to do; counted so a silent publisher shows
        for collected, batch in zip(per_member, batches):
            collected.append(batch)
    refusals = []
    for member, collected in zip(members, per_member):
        if collected:
            refusal = member.count_input(ingest_batch(member.buffer, TransformBatch.concatenate(collected),
                                                      now_s=now_s), count_empty=False)
            refusals += [refusal] if refusal else []
    return errors, refusals, lags


def crowd_markers(members: Sequence[Member], clear: bool) -> list[MarkerData]:
    """One MarkerArray's markers: every shown character's held markers, after a DELETEALL when ``clear``
    (a character was dressed again, the garments or namespaces changed: the old markers go; the others'
    follow in the same message, so RViz never shows them missing)."""
    markers = [m for member in members for m in member.markers]
    if clear and markers:
        newest = max((member.held[1] for member in members), key=lambda stamp: stamp)
        markers.insert(0, delete_all(markers[0].frame_id, newest))
    return markers

