"""Experiments on the twin: trials, campaigns, Stage 3, fault campaigns, consistency, reports.

The paper's validation metrics live in :mod:`jackson.experiments.metrics`; the calibration
procedures that change the robot's files stay in :mod:`jackson.calibration`.
"""
