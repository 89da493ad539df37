"""The state estimate's parts: wheel odometry and the EKF.

They import nothing else of the host; the pipeline (:mod:`jackson.host.core`) puts them
together.
"""
