from garment_sim_ros.cli import main

raise SystemExit(main(["table1", "--json"]))
