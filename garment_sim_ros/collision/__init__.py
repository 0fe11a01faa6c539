"""Quadric bounding volumes and adaptive static/dynamic collision handling (memo §6, ROS-free)."""
