"""Vendors recognised from a robot description's name: the controller's vendor and the joint
coupling conventions a vendor's streaming interface applies (ABB's coupled axes 2 and 3,
FANUC's J2/J3 interaction)."""

from __future__ import annotations

import re

# ROS-Industrial's drivers couple joint 3 to joint 2 on these arms (the J23_factor of the
# fanuc_*_support launch files, the J23_coupled of abb_*_support and abb_experimental):
# controller axis 3 = URDF joint 3 + factor x URDF joint 2.
_ABB_COUPLED = (
    "irb1600",
    "irb2400",
    "irb4400",
    "irb52",
    "irb5400",
    "irb6650s",
    "irb6700",
    "irb7600",
)


_FANUC_PLUS = ("m430ia",)  # J23_factor -1: the streamer adds joint 2


def vendor_conventions(robot_name: str) -> tuple[str | None, float | None]:
    """(vendor, J2-J3 coupling factor or None) of a robot from the vendors' ROS description
    packages, by its URDF name (``abb_irb2400``, ``fanuc_lrmate200id``, ``kuka_kr16_2``,
    ``ur5``, ``panda``, ``motoman_gp7``, ``staubli_tx2_60``, ``kuka_lbr_iiwa_14_r820``,
    ``m1013``); (None, None) when the name says nothing.  KUKA's 7-axis LBR family (iiwa,
    Med) runs Sunrise, not KRL: ``kuka_sunrise``."""
    name = robot_name.lower()
    if re.match(r"^(kuka_)?(lbr|iiwa|med\d)", name):
        return "kuka_sunrise", None
    if re.match(r"^(motoman_|yaskawa_|gp\d|mh\d|hc\d|ma\d|mpx?\d|sia\d)", name):
        return "yaskawa", None
    if re.match(r"^(staubli_|tx2?_?\d|rx\d|ts2?_?\d)", name):
        return "staubli", None
    if re.match(r"^(abb_)?irb", name):
        model = re.sub(r"^abb_", "", name)
        return "abb", (1.0 if model.startswith(_ABB_COUPLED) else None)
    if re.match(r"^(fanuc_|lrmate|m\d+i|cr\d+i|r\d+i)", name):
        model = re.sub(r"^fanuc_", "", name)
        return "fanuc", (1.0 if model.startswith(_FANUC_PLUS) else -1.0)
    if re.match(r"^(kuka_|kr\d)", name):
        return "kuka", None
    if re.match(r"^(ur\d|ur_|universal)", name):
        return "ur", None
    if re.match(r"^(panda|fr3|franka)", name):
        return "franka", None
    if re.match(r"^(doosan_|[mh]\d{4}|a\d{4}|e\d{4})", name):  # after FANUC's M-2000iA
        return "doosan", None
    return None, None
