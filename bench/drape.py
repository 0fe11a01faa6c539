"""``make bench``'s drape: ``garment-sim drape --json`` (n = 64), then newton VBD on the same scene in the same
run (``../shared/peers/warp_cloth.py``, one CPU thread), so that the ratio ``make bench`` reports compares two
timings under the same load (this machine's day-to-day and load swings are larger than the ratio's target
margin). Newton runs when the peers' virtualenv is present (``PEERS_VENV``, default /tmp/peers-venv, created as
``../shared/peers/README.md`` says); otherwise a message says how. ``DRAPE_FRAMES`` (default: the drape's 90)
timed frames for both; newton's JSON line carries its ``engine``."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

from garment_sim_ros.cli import main
from garment_sim_ros.commands.drape import DEFAULT_FRAMES, DEFAULT_N

frames = os.environ.get("DRAPE_FRAMES", str(DEFAULT_FRAMES))
status = main(["drape", "--json", "--frames", frames])
# the peers' folder and venv as bench/peers.py finds them
peers = Path(os.environ.get("PEERS", Path(__file__).resolve().parents[2] / "shared" / "peers"))
python = Path(os.environ.get("PEERS_VENV", "/tmp/peers-venv")) / "bin" / "python"
newton = peers / "warp_cloth.py"
if not python.is_file() or not newton.is_file():
    print(f"drape: newton VBD skipped: no {python} (or no {newton}); create the peers' venv as "
          f"{peers / 'README.md'} says, then: make bench BENCHES=drape PEERS_VENV=/path/to/venv", flush=True)
    raise SystemExit(status)
# cwd /tmp as run_all.sh: the engines write logs into the working directory
done = subprocess.run([str(python), str(newton), "--n", str(DEFAULT_N), "--frames", frames], cwd="/tmp",
                      stdout=subprocess.PIPE, text=True)
for line in done.stdout.splitlines():
    if line.startswith("{"):
        print(line, flush=True)
raise SystemExit(status or done.returncode)
