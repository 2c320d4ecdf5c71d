"""Robot programs out: one writer module per language over the resolved program
(:mod:`.common`); each ``write(program, options) -> {file name: text}``."""

from __future__ import annotations

from dataclasses import dataclass

FORMATS = ("urscript", "krl", "rapid", "fanuc", "inform", "val3", "drl", "sunrise", "csv")
# the language of each vendor's controller (a device's controller.vendor)
VENDOR_FORMATS = {
    "ur": "urscript",
    "kuka": "krl",
    "abb": "rapid",
    "fanuc": "fanuc",
    "yaskawa": "inform",
    "staubli": "val3",
    "doosan": "drl",
    "kuka_sunrise": "sunrise",
}
# vendors rworld knows and writes no language for yet: why, for the message
VENDOR_WITHOUT_FORMAT = {
    "franka": "Franka's controllers take no program file rworld writes (the robot is driven "
    "through libfranka / franka_ros at 1 kHz): export with --format csv",
    "kinova": "Kinova's Kortex controllers take no program file rworld writes (the arm is "
    "driven through the Kortex API or ros2_kortex): export with --format csv",
    "denso": "DENSO's controllers run PacScript, which rworld does not write yet: export with "
    "--format csv",
    "epson": "Epson's controllers run SPEL+, which rworld does not write yet: export with "
    "--format csv",
}


@dataclass(frozen=True)
class Signals:
    """The digital outputs that grasp / release, tool changes and camera captures drive, the
    digital input that a guarded move's sensor closes, and the first position register
    (FANUC) or position variable (INFORM) that keeps a probe's contact and a capture's pose."""

    gripper: int = 1
    tool_changer: int = 2
    sensor: int = 1
    contact_register: int = 101  # FANUC's PR[n], INFORM's P<n>: where contact 1 is kept
    camera: int = 3  # the camera's trigger: on for the exposure
    capture_register: int = 151  # FANUC's PR[n], INFORM's P<n>: where capture 1's pose is kept

    def output(self, signal: str) -> int:
        """The output number of ``signal`` ("gripper", "tool_changer" or "camera")."""
        return {"gripper": self.gripper, "tool_changer": self.tool_changer}.get(signal, self.camera)
