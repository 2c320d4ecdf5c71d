"""Trajectory planning: time-optimal timing under torque limits, payload capacity."""
