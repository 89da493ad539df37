"""Stage 3 on the host: occupancy grids, mapping, localization and planning.

Every module works on MCU time and plain numpy arrays, free of I/O, so the same code runs in
the daemon against the robot, against the twin in lockstep, and in replay.
"""
