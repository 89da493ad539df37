"""The Jackson UGV's nominal geometry (the paper's Table 1 and Eq. A8): the one place the
defaults of the host's beliefs and of the twin's true robot come from."""

WHEEL_RADIUS_M = 0.033  # r_run
WHEEL_SEPARATION_M = 0.198  # B_run, the twin's track width
TICKS_PER_REV = 621.0  # C_e,run per wheel, 4x quadrature: floor calibration 652 x 0.9525
