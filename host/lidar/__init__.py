"""The RPLIDAR A1M8 on the host: Slamtec's serial protocol and a driver for the sensor."""
