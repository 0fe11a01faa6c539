"""``make bench``'s summary (``bench_report``): the figures against their targets and the ratios to the
roofline and the peers of the same run, from JSON lines as the benchmarks print them (no timing here)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from garment_sim_ros.bench_report import figures, table

ROWS = [
    {"bench": "roofline", "particles": 676, "particle_substeps_per_s": 7.0e6, "frame_ms": 0.58},
    {"bench": "roofline", "particles": 4096, "particle_substeps_per_s": 6.0e6, "frame_ms": 4.1},
    {"bench": "roofline", "particles": 19881, "particle_substeps_per_s": 6.0e6, "frame_ms": 20.0},
    {"bench": "table1", "garment": "pants", "mass_points": 662, "integration_ms": 0.1, "collision_ms": 0.1},
    {"bench": "table1", "garment": "one_piece", "mass_points": 720, "integration_ms": 0.7, "collision_ms": 0.46},
    {"bench": "scale", "mass_points": 5000, "step_ms": 10.0, "publish_ms": 1.0, "particle_substeps_per_s": 3.0e6,
     "threads": 2},
    {"bench": "scale", "mass_points": 20100, "step_ms": 14.0, "publish_ms": 2.0, "particle_substeps_per_s": 8.6e6,
     "threads": 2},
    {"bench": "drape", "n": 64, "particles": 4096, "ms_per_frame": 8.0, "max_stretch": 1.05,
     "max_penetration_m": 0.0005, "final_top_z_m": 0.255},
    {"bench": "peers", "engine": "warp/newton-vbd", "n": 64, "ms_per_frame": 500.0},
    {"bench": "peers", "engine": "mujoco-flex-discrete-CG-slide", "n": 64, "ms_per_frame": 520.0},
    {"bench": "peers", "engine": "warp/newton-vbd", "n": 20, "ms_per_frame": 60.0},
    {"bench": "crowd", "summary": True, "characters_at_60fps": 17, "characters_at_60fps_linear": 18,
     "ms_per_character": 0.9, "threads": 2},
]


def test_figures_hold_or_miss_their_targets_with_ratios_to_the_same_runs_roofline_and_peers():
    by_name = {f["figure"].split(" (")[0].split(",")[0]: f for f in figures(ROWS)}
    one_piece = by_name["one-piece integration + collision"]
    assert one_piece["value"] == 1.16 and one_piece["holds"] is False  # > 0.4 ms
    assert one_piece["ratio_to_roofline"] == 2.0  # 1.16 / 0.58: the roofline row nearest 720 points
    dress = by_name["20100-point dress"]
    assert dress["value"] == 62.5 and dress["holds"] is True and dress["ratio_to_roofline"] == 0.7  # 14 / 20
    rate = next(f for f in figures(ROWS) if f["figure"].startswith("particle-substeps/s per core"))
    assert rate["value"] == 1_500_000 and rate["holds"] is False  # the worst from 5 000 points, per thread
    assert rate["ratio_to_roofline"] == 4.0  # 6 M / 1.5 M
    drape = by_name["drape n = 64"]
    assert drape["peer_speedup"] == {"warp/newton-vbd": 62.5, "mujoco-flex-discrete-CG-slide": 65.0}
    assert drape["holds"] is True and drape["ratio_to_roofline"] == 1.95  # 8 / 4.1
    crowd = by_name["characters at 60 fps in one process"]
    assert crowd["value"] == 17 and crowd["holds"] is True
    assert "| drape n = 64 | 8.0 |" in table(ROWS)


def test_the_drape_target_needs_newton_vbd_measured_in_the_same_run():
    without_peers = [row for row in ROWS if row["bench"] != "peers"]
    drape = next(f for f in figures(without_peers) if f["figure"].startswith("drape"))
    assert drape["holds"] is False and drape["peer_speedup"] == {} and "not measured" in drape["note"]


def test_the_drape_ratio_takes_newton_as_the_drape_bench_ran_it_beside_ours():
    beside = {"bench": "drape", "engine": "warp/newton-vbd", "n": 64, "particles": 4096, "ms_per_frame": 2000.0}
    drape = next(f for f in figures([*ROWS, beside]) if f["figure"].startswith("drape"))
    # 2000 / 8 (not the peers bench's 500 / 8), and newton's row is not taken for ours
    assert drape["value"] == 8.0 and drape["peer_speedup"]["warp/newton-vbd"] == 250.0
    assert drape["peer_speedup"]["mujoco-flex-discrete-CG-slide"] == 65.0


def test_the_drape_bench_says_how_to_add_newton_when_the_peers_venv_is_absent(tmp_path):
    script = Path(__file__).resolve().parents[1] / "bench" / "drape.py"
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300,
                          env={"PEERS_VENV": str(tmp_path / "no-venv"), "DRAPE_FRAMES": "1", "PATH": "/usr/bin:/bin",
                               "PYTHONPATH": str(script.parents[1])})
    rows = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    assert done.returncode == 0 and "drape: newton VBD skipped: no" in done.stdout
    assert len(rows) == 1 and rows[0]["n"] == 64 and rows[0]["frames"] == 1 and "engine" not in rows[0]


def test_peers_are_skipped_with_a_message_when_their_venv_is_absent(tmp_path):
    script = Path(__file__).resolve().parents[1] / "bench" / "peers.py"
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=60,
                          env={"PEERS_VENV": str(tmp_path / "no-venv"), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0 and "peers: skipped: no peers venv at" in done.stdout
