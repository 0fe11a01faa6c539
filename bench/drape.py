from garment_sim_ros.cli import main

raise SystemExit(main(["drape", "--json"]))
