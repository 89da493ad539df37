"""The state estimate's parts: wheel odometry, the EKF and the sensors' health monitor.

They import nothing else of the host; the pipeline (:mod:`jackson.host.core`) puts them
together.
"""
