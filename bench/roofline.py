"""The calibration ``../shared/peers/roofline.py`` (one plain numba substep, one thread, no broad phase)
run with this venv in the same ``make bench``, its lines as JSON: particles, springs, substep_us,
particle_substeps_per_s and frame_ms (6 substeps), with the load average.

``PEERS`` (default ../shared/peers) is its folder; ``ROOFLINE_NX`` its grid sizes (default 26 64 141:
676, 4 096 and 19 881 particles, the one-piece, the drape n = 64 and the 20 000-point dress)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

from garment_sim_ros.benchmarking import load_average

REPO = Path(__file__).resolve().parents[1]
SCRIPT = Path(os.environ.get("PEERS", REPO.parent / "shared" / "peers")) / "roofline.py"
KEYS = {"particles": int, "springs": int, "substep_us": float, "particle_substeps_per_s": float,
        "frame_ms(6 substeps)": float}

if not SCRIPT.is_file():
    print(f"roofline: skipped: no {SCRIPT} (set PEERS=/path/to/shared/peers)", flush=True)
    raise SystemExit(0)
env = {**os.environ, "ROOFLINE_NX": os.environ.get("ROOFLINE_NX", "26 64 141")}
done = subprocess.run([sys.executable, str(SCRIPT)], env=env, capture_output=True, text=True, check=True)
for line in done.stdout.splitlines():
    fields = dict(re.findall(r"([\w()\s]+?)=\s*([-+.\deE]+)", line))  # "particles=   676 ... frame_ms(6 substeps)=1.1"
    fields = {key.strip(): value for key, value in fields.items()}
    if set(KEYS) <= set(fields):
        row = {key.replace("(6 substeps)", ""): kind(fields[key]) for key, kind in KEYS.items()}
        print(json.dumps({**row, "threads": 1, "load_1min": load_average()}), flush=True)
