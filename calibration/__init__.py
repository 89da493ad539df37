"""Calibration procedures (Appendix A and B), the runs they record and the YAML update.

The trials, campaigns and the paper's validation metrics are in :mod:`jackson.experiments`.
"""
