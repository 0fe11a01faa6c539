"""The peers (newton VBD, MuJoCo, PyBullet) on the drape scene, ``../shared/peers/run_all.sh``, in the
same ``make bench``: their JSON lines as they come. Only when their virtualenv is present (heavy:
created as ``../shared/peers/README.md`` says, never by this script): ``PEERS_VENV`` (default
/tmp/peers-venv; run_all.sh's ``VENV``); otherwise a message says how and nothing is run.
``PEER_NS`` (default 64) and ``PEER_FRAMES`` (default 30) are the sizes and timed frames."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PEERS = Path(os.environ.get("PEERS", REPO.parent / "shared" / "peers"))
VENV = Path(os.environ.get("PEERS_VENV", "/tmp/peers-venv"))

if not (VENV / "bin" / "python").is_file() or not (PEERS / "run_all.sh").is_file():
    print(f"peers: skipped: no peers venv at {VENV} (or no {PEERS / 'run_all.sh'}); create it as "
          f"{PEERS / 'README.md'} says, then: make bench PEERS_VENV={VENV}", flush=True)
    raise SystemExit(0)
env = {**os.environ, "VENV": str(VENV), "NS": os.environ.get("PEER_NS", "64"),
       "FRAMES": os.environ.get("PEER_FRAMES", "30"), "OUT": str(REPO / "out" / "peers.jsonl")}
(REPO / "out").mkdir(exist_ok=True)
raise SystemExit(subprocess.run(["bash", str(PEERS / "run_all.sh")], env=env, stdout=sys.stdout).returncode)
