"""Simulation of symbolic programs for several devices on one clock (report, section 5)."""
