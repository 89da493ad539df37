"""The actuation chain: limits, kinematics, PWM shaping, and the motor-driver outputs."""
