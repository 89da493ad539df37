"""The pymunk digital twin: the robot for everyone without one. Never imports ``jackson.host``."""
