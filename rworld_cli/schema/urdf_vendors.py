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


# vendor prefixes of the ROS packages' robot and package names (abb_crb15000_support,
# fanuc_crx10ia_support, motoman_hc10_support, ...), each vendor's
_PREFIXES = {
    "abb": "abb",
    "fanuc": "fanuc",
    "kuka": "kuka",
    "motoman": "yaskawa",
    "yaskawa": "yaskawa",
    "staubli": "staubli",
    "ur": "ur",
    "universal": "ur",
    "doosan": "doosan",
    "franka": "franka",
    "kinova": "kinova",
    "kortex": "kinova",
    "denso": "denso",
    "epson": "epson",
}


def vendor_of(robot_name: str, package: str | None = None) -> str | None:
    """The vendor of a robot from the vendors' ROS description packages, by its URDF name or
    by the name of the package its file is in (``abb_crb15000_support``): a vendor's prefix
    (``abb_``, ``motoman_``, ``kinova_``, ...) or a model family the vendor names its robots
    by (ABB IRB, CRB, GoFa, YuMi; FANUC LR Mate, M, R, CR, CRX; Yaskawa GP, MH, HC, MA, SIA;
    KUKA KR, LBR iiwa and Med; UR; Stäubli TX, RX, TS; Doosan M, H, A, E; Franka Panda, FR3;
    Kinova Gen3, Jaco; DENSO VS, VP, COBOTTA); None when neither says."""
    for text in (robot_name, package or ""):
        name = text.lower()
        if re.match(r"^(kuka_)?(lbr|iiwa|med\d)", name):
            return "kuka_sunrise"
        prefix = re.match(r"^([a-z]+)[_\-]", name)
        if prefix and prefix.group(1) in _PREFIXES:
            vendor = _PREFIXES[prefix.group(1)]
            if vendor == "kuka" and re.match(r"^kuka_(lbr|iiwa|med)", name):
                return "kuka_sunrise"
            return vendor
        families = (
            (r"^(gp\d|mh\d|hc\d|ma\d|mpx?\d|sia\d|ar\d{3,4})", "yaskawa"),
            (r"^(tx2?_?\d|rx\d|ts2?_?\d)", "staubli"),
            (r"^(irb|crb|gofa|yumi|swifti)", "abb"),
            (r"^(lrmate|m\d+i|crx|cr\d+i|r\d+i)", "fanuc"),
            (r"^kr\d", "kuka"),
            (r"^ur(\d|$)", "ur"),
            (r"^(panda|fr3|fer\b|fp3)", "franka"),
            (r"^(gen3|jaco|j2[ns]\d|mico)", "kinova"),
            (r"^(vs\d{3}|vp\d|cobotta)", "denso"),
            (r"^([mh]\d{4}|a\d{4}|e\d{4})", "doosan"),  # after FANUC's M-2000iA
        )
        for pattern, vendor in families:
            if re.match(pattern, name):
                return vendor
    return None


def vendor_conventions(
    robot_name: str, package: str | None = None
) -> tuple[str | None, float | None]:
    """(vendor, J2-J3 coupling factor or None) of a robot from the vendors' ROS description
    packages (:func:`vendor_of`: ``abb_irb2400``, ``fanuc_lrmate200id``, ``kuka_kr16_2``,
    ``ur5``, ``panda``, ``motoman_gp7``, ``staubli_tx2_60``, ``kuka_lbr_iiwa_14_r820``,
    ``m1013``, ``abb_crb15000_5_95``, ``gen3``); (None, None) when neither the name nor the
    package says.  KUKA's 7-axis LBR family (iiwa, Med) runs Sunrise, not KRL:
    ``kuka_sunrise``."""
    vendor = vendor_of(robot_name, package)
    model = re.sub(r"^[a-z]+[_\-]", "", robot_name.lower())
    if vendor == "abb":
        return vendor, (1.0 if model.startswith(_ABB_COUPLED) else None)
    if vendor == "fanuc":
        return vendor, (1.0 if model.startswith(_FANUC_PLUS) else -1.0)
    return vendor, None
