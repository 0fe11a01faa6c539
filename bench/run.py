"""``make bench``: every benchmark in one run, then the issue-15 figures as a table.

Runs ``bench/<name>.py`` for each name (``--only`` picks some), echoing what they print; every JSON
line is also written, tagged ``"bench": name``, to ``out/bench.jsonl``. Then the figures against
their targets, with ratios to the roofline and the peers of this run (``garment_sim_ros.bench_report``),
as JSON lines (``"bench": "summary"``) and a Markdown table, with the load average. A benchmark that
fails is named and the run goes on; the exit status is 1 if any failed."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from garment_sim_ros.bench_report import figures, table
from garment_sim_ros.benchmarking import load_average

HERE = Path(__file__).resolve().parent
BENCHES = ("roofline", "table1", "scale", "publish", "drape", "crowd", "tf_throughput", "rerun_rate", "peers", "fused",
           "length_correction")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=BENCHES, default=list(BENCHES), help="these benchmarks only")
    parser.add_argument("--out", type=Path, default=HERE.parent / "out" / "bench.jsonl")
    args = parser.parse_args()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    rows, failed = [], []
    with args.out.open("w") as out:
        for name in (b for b in BENCHES if b in args.only):
            print(f"== {name} (load {load_average()})", flush=True)
            process = subprocess.Popen([sys.executable, str(HERE / f"{name}.py")], stdout=subprocess.PIPE, text=True)
            for line in process.stdout:
                print(line, end="", flush=True)
                if line.startswith("{"):
                    row = {"bench": name, **json.loads(line)}
                    rows.append(row)
                    out.write(json.dumps(row) + "\n")
            if process.wait() != 0:
                failed.append(name)
        summary = [{"bench": "summary", **f} for f in figures(rows)]
        for row in summary:
            out.write(json.dumps(row) + "\n")
    print(f"== summary (load {load_average()}; every line in {args.out})")
    for row in summary:
        print(json.dumps(row))
    print(table(rows))
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
