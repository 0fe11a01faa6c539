"""The node's runtime without ROS: the frame loop (``character_loop``), its statistics, the node's
parameter table and params file, /tf decoding, MarkerArray CDR encoding and rosbag2 I/O (through
``rosbags``, not rclpy). ``ros/`` wraps it in rclpy; ``garment-sim replay`` runs it on a bag.
Imports no rclpy or ROS message module (``test/test_layers.py``)."""
