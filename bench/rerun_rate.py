"""How fast the demo's Rerun recording grows, and what logging it costs the frame loop.

Runs ``garment-sim demo --duration D --rerun-every-n N --json`` for N in 1, 2, 4 (each in its own
process) and prints the recording's growth in MB/s of the recording's time (its size over the
span of its ``sim_time`` timeline) beside the demo's fps and tick time.

    .venv/bin/python bench/rerun_rate.py [--duration 10] [--every-n 1,2,4]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path


def recording_span_s(path: Path) -> float:
    """Seconds between the first and the last ``sim_time`` stamp of a recording."""
    from rerun.chunk import RrdReader

    stamps = []
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        if "sim_time" in batch.schema.names:
            stamps += [t.value for t in batch.column("sim_time")]
    return (max(stamps) - min(stamps)) * 1e-9


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0, help="seconds of dressed walking per run")
    parser.add_argument("--every-n", default="1,2,4", help="rerun_every_n values, comma-separated")
    args = parser.parse_args()
    print(f"{'every_n':>7} {'MB':>7} {'span s':>7} {'MB/s':>6} {'fps':>6} {'tick ms':>8}")
    with tempfile.TemporaryDirectory() as folder:
        for every_n in (int(n) for n in args.every_n.split(",")):
            rrd = Path(folder) / f"demo_{every_n}.rrd"
            result = subprocess.run([sys.executable, "-m", "garment_sim_ros.cli", "demo", "--duration",
                                     str(args.duration), "--rerun-every-n", str(every_n), "--rrd", str(rrd), "--json"],
                                    capture_output=True, text=True, check=True)
            summary = json.loads(result.stdout)
            size_mb, span = rrd.stat().st_size / 1e6, recording_span_s(rrd)
            print(f"{every_n:>7} {size_mb:7.2f} {span:7.2f} {size_mb / span:6.2f} {summary['fps']:6.1f} "
                  f"{summary['tick_ms']:8.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
