from garment_sim_ros.cli import main

raise SystemExit(main(["crowd", "--garments", "one_piece", "--json"]))
