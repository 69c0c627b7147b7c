"""Servo-controller export, calibration and the Dynamixel Protocol 1.0 bus for MX-64T servos."""
