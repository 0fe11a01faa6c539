"""``make bench``'s summary: the issue-15 figures from one run's JSON lines, against their targets and
as ratios to the roofline and the peers measured in the same run (ROS-free).

The rows come from ``bench/run.py``, each a benchmark's JSON line tagged with ``"bench"`` (its script's
name): ``table1``, ``scale``, ``drape``, ``crowd`` (the project), ``roofline`` (``../shared/peers/roofline.py``:
one plain numba substep, one thread, no broad phase) and ``peers`` (newton VBD, MuJoCo, PyBullet on the
drape scene, when their venv is present). A ratio compares like with like: per particle count the
roofline row nearest in particles, per drape size the peers' rows of that ``n``; where the ``drape`` bench
ran newton VBD right after ours (its row has an ``engine``), that timing rather than the ``peers`` bench's.
``ratio_to_roofline`` is ours / roofline in time (above 1: slower than the plain kernel); ``peer_speedup`` is
the peer's time / ours (above 1: we are faster).
"""

from __future__ import annotations

from typing import Iterable

# The targets (issue 15, "Targets"); each figure's row says whether it holds.
ONE_PIECE_MS = 0.4  # integration + collision per frame, Table 1 protocol
DRESS_POINTS = 20_000  # the big dress...
DRESS_FPS = 60.0  # ...whole frame including publish
RATE_PER_CORE = 5e6  # particle-substeps/s per core...
RATE_FROM_POINTS = 5_000  # ...from this size up
DRAPE_N = 64
DRAPE_STRETCH = 1.10
DRAPE_PENETRATION_M = 0.001
DRAPE_ON_SPHERE_Z_M = 0.2  # the sheet's top still above this at the end: on the 0.25 m sphere
DRAPE_SPEEDUP = 50.0  # against newton VBD in the same run
CROWD_CHARACTERS = 16


def _of(rows: Iterable[dict], bench: str) -> list[dict]:
    return [row for row in rows if row.get("bench") == bench]


def _nearest_roofline(rows: list[dict], particles: int) -> dict | None:
    roofline = _of(rows, "roofline")
    return min(roofline, key=lambda r: abs(r["particles"] - particles)) if roofline else None


def _ratio(ours: float | None, theirs: float | None) -> float | None:
    return round(ours / theirs, 2) if ours and theirs else None


def figures(rows: list[dict]) -> list[dict]:
    """One dict per figure: name, value, unit, target, holds (None: not measured), ratios where they apply."""
    out = []

    def add(name, value, unit, target, holds, roofline=None, peers=None, note=""):
        out.append({"figure": name, "value": value, "unit": unit, "target": target, "holds": holds,
                    "ratio_to_roofline": roofline, "peer_speedup": peers or {}, "note": note})

    one_piece = next((r for r in _of(rows, "table1") if r.get("garment") == "one_piece"), None)
    if one_piece:
        ms = round(one_piece["integration_ms"] + one_piece["collision_ms"], 4)
        plain = _nearest_roofline(rows, one_piece["mass_points"])
        add("one-piece integration + collision (Table 1 protocol)", ms, "ms/frame", f"<= {ONE_PIECE_MS}",
            ms <= ONE_PIECE_MS, _ratio(ms, plain and plain["frame_ms"]),
            note=f"{one_piece['mass_points']} points; roofline at {plain['particles']}" if plain else "")
    scale = _of(rows, "scale")
    if scale:
        dress = min(scale, key=lambda r: abs(r["mass_points"] - DRESS_POINTS))
        frame_ms = dress["step_ms"] + dress["publish_ms"]
        plain = _nearest_roofline(rows, dress["mass_points"])
        add(f"{dress['mass_points']}-point dress, step + publish", round(1e3 / frame_ms, 1), "fps",
            f">= {DRESS_FPS:g}", 1e3 / frame_ms >= DRESS_FPS, _ratio(dress["step_ms"], plain and plain["frame_ms"]),
            note="ratio: step against the roofline's frame")
        big = [r for r in scale if r["mass_points"] >= RATE_FROM_POINTS]
        if big:
            worst = min(big, key=lambda r: r["particle_substeps_per_s"] / r.get("threads", 2))
            per_core = worst["particle_substeps_per_s"] / worst.get("threads", 2)
            plain = _nearest_roofline(rows, worst["mass_points"])
            add(f"particle-substeps/s per core, >= {RATE_FROM_POINTS} points (worst: {worst['mass_points']})",
                round(per_core), "1/s", f">= {RATE_PER_CORE:.0e}", per_core >= RATE_PER_CORE,
                _ratio(plain and plain["particle_substeps_per_s"], per_core),
                note="process rate / numba threads; ratio: roofline rate / ours")
    drape = next((r for r in _of(rows, "drape") if r.get("n") == DRAPE_N and "engine" not in r), None)
    if drape:
        # the peers' bench, then newton as the drape's bench ran it beside ours (the closer in time: it wins)
        peers = {p["engine"]: _ratio(p["ms_per_frame"], drape["ms_per_frame"])
                 for p in _of(rows, "peers") + _of(rows, "drape") if p.get("n") == DRAPE_N and "engine" in p}
        vbd = next((v for k, v in peers.items() if "vbd" in k), None)
        top = drape.get("final_top_z_m")
        sane = (drape["max_stretch"] <= DRAPE_STRETCH and drape["max_penetration_m"] <= DRAPE_PENETRATION_M
                and top is not None and top >= DRAPE_ON_SPHERE_Z_M)
        plain = _nearest_roofline(rows, drape["particles"])
        add(f"drape n = {DRAPE_N}", drape["ms_per_frame"], "ms/frame",
            f"stretch <= {DRAPE_STRETCH}, penetration <= 1 mm, on the sphere, >= {DRAPE_SPEEDUP:g}x newton VBD",
            sane and vbd is not None and vbd >= DRAPE_SPEEDUP,
            _ratio(drape["ms_per_frame"], plain and plain["frame_ms"]),
            peers, note=f"stretch {drape['max_stretch']}, penetration {drape['max_penetration_m'] * 1e3:.2f} mm, "
                        f"top z {top}" + ("" if vbd is not None else "; newton VBD not measured in this run"))
    crowd = next((r for r in _of(rows, "crowd") if r.get("summary")), None)
    if crowd:
        add("characters at 60 fps in one process (one-piece each)", crowd["characters_at_60fps"], "characters",
            f">= {CROWD_CHARACTERS}", crowd["characters_at_60fps"] >= CROWD_CHARACTERS,
            note=f"{crowd['ms_per_character']} ms per character, linear fit {crowd['characters_at_60fps_linear']}; "
                 f"{crowd['threads']} thread(s)")
    return out


def table(rows: list[dict]) -> str:
    """The figures as a Markdown table, with the load average of the run."""
    lines = ["| figure | value | unit | target | holds | ours / roofline | peer time / ours | note |",
             "|---|---|---|---|---|---|---|---|"]
    for f in figures(rows):
        holds = {True: "yes", False: "no", None: "-"}[f["holds"]]
        peers = ", ".join(f"{k} {v}x" for k, v in f["peer_speedup"].items()) or "-"
        ratio = f["ratio_to_roofline"] if f["ratio_to_roofline"] is not None else "-"
        lines.append(f"| {f['figure']} | {f['value']} | {f['unit']} | {f['target']} | {holds} | "
                     f"{ratio} | {peers} | {f['note']} |")
    return "\n".join(lines)
