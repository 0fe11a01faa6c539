"""The garment: procedural meshes, the mass-spring model and the relative solver of the memo (ROS-free)."""
