"""The character: skeletons, joint maps, motion sources and the bounding volumes they define (ROS-free)."""
