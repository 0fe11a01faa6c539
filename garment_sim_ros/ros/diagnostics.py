"""The node's ``/diagnostics`` status: its level, message and figures from the loop, the frame
statistics and the input counters (a ``diagnostic_msgs/DiagnosticStatus``; the node publishes it).

OK running; WARN waiting, holding, behind the clock or lagging; ERROR for a skeleton that cannot be
mapped or a frame that failed since the last status.
"""

from __future__ import annotations

from collections import Counter
from typing import Any, Mapping, Sequence

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from ..runtime.character_loop import CharacterLoop, Status
from ..runtime.crowd import Member

LAG_WARNING_FRACTION = 0.1  # WARN when the garments fall behind by this share of the body's time...
LAG_WARNING_MIN_S = 0.001  # ...and by at least this much, s (a window right after a resume holds little time)


def level_and_message(loop: CharacterLoop, figures: Mapping[str, float], frame_failed: bool) -> tuple[bytes, str]:
    """The status level and message for the loop's state and the window's figures."""
    lagging = figures["lag_fraction"] > LAG_WARNING_FRACTION and figures["lag_s"] >= LAG_WARNING_MIN_S
    level, message = DiagnosticStatus.OK, loop.status
    if loop.status == Status.UNMAPPABLE or frame_failed:
        level = DiagnosticStatus.ERROR
    elif loop.status != Status.RUNNING or lagging:
        level = DiagnosticStatus.WARN
    if loop.detail:
        message = f"{loop.status}: {loop.detail}"
    elif lagging:
        message = (f"{loop.status}; too slow: the garments simulated only {1 - figures['lag_fraction']:.0%} of "
                   f"the body's time (max_substeps), {figures['lag_s']:.3f} s behind in total")
    return level, message


def status_values(loop: CharacterLoop, figures: Mapping[str, float], now_s: float, totals: Mapping[str, int],
                  counters: Mapping[str, Counter]) -> dict[str, str]:
    """Every figure as text: the window's ``figures``, the loop's state, ``totals`` (whole-run counts) and
    each counter's entries under ``<prefix>_<key>`` (``counters``: prefix -> Counter)."""
    values = {key: f"{value:.6g}" for key, value in figures.items()}
    values.update({
        "status": loop.status,
        "garments": " ".join(loop.garments),
        "mass_points": str(loop.mass_points),
        "quality_rate_hz": f"{loop.quality_rate_hz:.6g}",  # quality figures from the measured frames only
        "skeleton_age_s": f"{loop.skeleton_age(now_s):.6g}",
    })
    values.update({key: str(count) for key, count in totals.items()})
    for prefix, counter in counters.items():
        values.update({f"{prefix}_{key}": str(count) for key, count in sorted(counter.items())})
    return values


def diagnostic_status(name: str, hardware_id: str, level: bytes, message: str,
                      values: Mapping[str, str]) -> DiagnosticStatus:
    return DiagnosticStatus(level=level, name=name, message=message, hardware_id=hardware_id,
                            values=[KeyValue(key=k, value=v) for k, v in values.items()])


def crowd_statuses(node_name: str, members: Sequence[Member], values: Mapping[str, Any], now_s: float,
                   totals: Mapping[str, int], frame_failed: bool) -> list[DiagnosticStatus]:
    """One status per character: ``garment_sim: <node>`` for one, ``garment_sim: <node>: <prefix>`` in a crowd
    (hardware id: the prefix, or the fixed frame without one); ``totals`` are the node's."""
    statuses = []
    for member in members:
        figures = member.stats.window()
        level, message = level_and_message(member.loop, figures, frame_failed)
        counters = {"input": member.input_counts, "rejected": member.buffer.rejected,
                    "adjusted": member.buffer.adjusted, "glitch": member.buffer.glitches, "loop": member.loop.counts,
                    "solver": member.stats.recoveries}
        figures_text = status_values(member.loop, figures, now_s, {"total_frames": member.stats.total_frames, **totals},
                                     counters)
        name = f"garment_sim: {node_name}" + (f": {member.prefix.strip('/')}" if len(members) > 1 else "")
        statuses.append(diagnostic_status(name, member.prefix or values["fixed_frame"], level, message, figures_text))
    return statuses
