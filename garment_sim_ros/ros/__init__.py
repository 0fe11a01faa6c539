"""ROS 2 adapters: the nodes and message conversions. The only package that imports rclpy."""
