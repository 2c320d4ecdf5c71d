"""The report's hierarchy rules for affixments, shared by the loader and the runtime.

Section 2 of the world-modelling paper: devices > objects, sensors > frames.
Devices may hold objects, objects may not hold devices; sensors sit at the
objects' level; frames are the lowest level and hold only frames.
"""

from __future__ import annotations

OwnerKind = str  # "world" | "free" | "object" | "sensor" | "device"


def hierarchy_problem(
    child: str, child_kind: str, parent: str, parent_owner: str, owner_kind: OwnerKind
) -> tuple[str, str] | None:
    """Why ``child`` (an object, sensor or device) may not be affixed to frame ``parent``.

    Returns
    -------
    (key, message) or None
        ``key`` is the end to blame: ``"parent"`` or ``"child"``.
    """
    if parent_owner == child:
        return "parent", f"cannot affix '{child}' to its own frame '{parent}'"
    if owner_kind == "free":
        return (
            "parent",
            f"'{parent}' is a free frame; frames hold only frames, so affix '{child}' to world, "
            "an object or a device",
        )
    if child_kind == "device" and owner_kind in ("object", "sensor"):
        return "child", (
            f"{owner_kind} '{parent_owner}' cannot hold device '{child}': "
            "devices may hold objects, objects and sensors may not hold devices"
        )
    return None


def kind_problem(
    type_: str, kind: str | None, child_kind: str, owner_kind: OwnerKind
) -> str | None:
    """Why an affixment's ``kind`` does not fit its type and ends, or None."""
    if kind is None:
        return None
    if type_ == "non_rigid" and kind != "rests_on":
        return f"'{kind}' is a rigid affixment; use type: rigid, or kind: rests_on"
    if type_ == "rigid" and kind == "rests_on":
        return "'rests_on' is non-rigid (the child rests on the parent); use type: non_rigid"
    if kind == "grasp" and (owner_kind != "device" or child_kind == "device"):
        return "a grasp holds an object or sensor in a device's frame (a TCP or link)"
    if kind == "aggregation" and (owner_kind != "device" or child_kind != "device"):
        return "an aggregation affixes a device to another device"
    if kind == "tool" and owner_kind != "device":
        return "a tool is affixed to a device's frame (its flange or TCP)"
    if kind == "assembly" and (owner_kind != "object" or child_kind != "object"):
        return "an assembly affixes an object to another object"
    return None
