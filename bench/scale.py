from garment_sim_ros.cli import main

raise SystemExit(main(["scale", "--json"]))
