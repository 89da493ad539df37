"""Calibration procedures, the paper's validation metrics, trial campaigns and reports."""
