"""Device dynamics: Newton-Euler inverse dynamics, mass matrix, forward dynamics, statics,
payloads.
"""

from .core import DEFAULT_GRAVITY, DeviceDynamics, Payload, combine_inertials, integrate

__all__ = ["DEFAULT_GRAVITY", "DeviceDynamics", "Payload", "combine_inertials", "integrate"]
