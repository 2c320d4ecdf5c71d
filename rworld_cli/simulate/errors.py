"""Why a simulated program cannot run, or fails its check."""

from __future__ import annotations

from ..errors import UserError


class SimulationError(UserError):
    """A program cannot run: the message names the device, the step and the cause."""


class UnreachableTarget(SimulationError):
    """A move's target is out of the device's reach (IK, or a line leaving the workspace):
    the program is well formed but fails the check - exit 1, with the step."""

    exit_code = 1


class NoFreePath(UnreachableTarget):
    """A ``path: free`` move found no collision-free path to its target (exit 1, with the
    planner's reason, also as ``reason``)."""

    def __init__(self, message: str, reason: str = ""):  # default: unpickled in a fleet
        super().__init__(message)
        self.reason = reason
