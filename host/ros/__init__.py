"""ROS 2 interfaces of the host: the rclpy bridge node and rosbag2 recording."""
