"""``garment-sim``: one command line for the demo, the memo's experiments and the benchmarks.

Each sub-command lives in ``garment_sim_ros.commands.<name>`` and provides ``HELP``,
``add_arguments(parser)`` and ``run(args) -> int``. Modules are imported only when their
command runs, so ``garment-sim garments`` does not load rclpy.
"""

from __future__ import annotations

import argparse
import importlib
import sys

COMMANDS = {
    "garments": "garment_sim_ros.commands.garments",
    "simulate": "garment_sim_ros.commands.simulate",
    "evaluate": "garment_sim_ros.commands.evaluate",
    "fig5": "garment_sim_ros.commands.fig5",
    "fig6": "garment_sim_ros.commands.fig6",
    "skeleton": "garment_sim_ros.commands.skeleton",
    "demo": "garment_sim_ros.commands.demo",
    "replay": "garment_sim_ros.commands.replay",
    "snapshot": "garment_sim_ros.commands.snapshot",
    "table1": "garment_sim_ros.commands.table1",
    "scale": "garment_sim_ros.commands.scale",
    "publish": "garment_sim_ros.commands.publish",
    "drape": "garment_sim_ros.commands.drape",
    "crowd": "garment_sim_ros.commands.crowd",
}

# One-line help without importing the modules (some import rclpy or rerun).
SUMMARIES = {
    "garments": "list the garment templates at a resolution (mass points, edges, springs, triangles)",
    "simulate": "headless run of garments on the walking character or a BVH clip, per-frame figures, --export .npz",
    "evaluate": "do the garments stay on real motion: BVH clips x garments x speeds x frame rates, pass/fail",
    "fig5": "memo Fig. 5: error of the simplified dynamic collision detection",
    "fig6": "memo Fig. 6: dynamic vs static collision handling speed at equal error",
    "skeleton": "read a BVH clip: detected joint map, fitted volumes, clip info",
    "demo": "run the node with the walking character, write out/demo.rrd, print a summary",
    "replay": "replay a recorded rosbag2 (MCAP, SQLite3) of /tf offline: Rerun recording, optional markers bag",
    "snapshot": "render PNG pictures of a dressed character, its volumes or its canonical pose",
    "table1": "memo Table 1 benchmark: per-stage time per frame for the four garments",
    "scale": "cost per frame against resolution (500 to 50 000 mass points)",
    "publish": "MarkerArray publishing cost: numpy CDR path against rclpy Point objects",
    "drape": "the classic drape scene: square cloth over a moving sphere",
    "crowd": "how many characters one process dresses at 60 fps, cost against their number",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="garment-sim",
        description="Real-time garment simulation on a moving character: demo, experiments, benchmarks.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        sub.add_parser(name, help=SUMMARIES[name], add_help=False)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help") or argv[0] not in COMMANDS:
        parser = build_parser()
        if argv and argv[0] not in ("-h", "--help"):
            parser.print_usage(sys.stderr)
            print(f"garment-sim: unknown command {argv[0]!r}; choose from {', '.join(COMMANDS)}", file=sys.stderr)
            return 2
        parser.print_help()
        return 0
    name, rest = argv[0], argv[1:]
    module = importlib.import_module(COMMANDS[name])
    parser = argparse.ArgumentParser(prog=f"garment-sim {name}", description=module.HELP)
    module.add_arguments(parser)
    args = parser.parse_args(rest)
    try:
        return int(module.run(args) or 0)
    except (ValueError, OSError) as error:  # bad input or parameters: a message, not a traceback
        print(f"garment-sim {name}: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
