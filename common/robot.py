"""The Jackson UGV's nominal geometry and sensors (the paper's Table 1, Eq. A8 and A21): the one
place the defaults of the host's beliefs, the twin's true robot and the metrics come from."""

WHEEL_RADIUS_M = 0.033  # r_run
WHEEL_SEPARATION_M = 0.198  # B_run, the twin's track width
TICKS_PER_REV = 621.0  # C_e,run per wheel, 4x quadrature: floor calibration 652 x 0.9525
# the conservative collision envelope, robot frame [m] (Eq. A21): the Stage 3 costmap's
# footprint, the twin's body and the d_min metric
ENVELOPE_X_M = (-0.135, 0.135177)
ENVELOPE_Y_M = (-0.135439, 0.135)
LIDAR_RANGE_NOISE_M = 0.010  # RPLIDAR A1M8 range noise, one sigma [m]
