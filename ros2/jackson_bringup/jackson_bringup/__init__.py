"""jackson_bringup: the Jackson UGV's URDF, launch file and Nav2 / slam_toolbox parameters for a
system ROS 2, and the ``mcu_clock`` node that puts the robot's MCU time on /clock."""
