"""The host daemon that runs on the Jetson: transport, odometry, EKF, control, actuation.

It never imports ``jackson.sim`` or ``jackson.calibration``.
"""
