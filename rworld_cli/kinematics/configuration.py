"""Arm configurations of 6-axis arms: shoulder front or back, elbow up or down, wrist flipped or
not - the three choices an industrial robot controller asks for beside a Cartesian target
(ABB ``confdata``, KUKA Status, FANUC ``CONFIG``).

The definitions are geometric, so they hold whatever sign a URDF gives an axis:

- **shoulder**: ``front`` when the wrist centre lies on the side of axis 1 the arm reaches to at
  the zero pose (in the frame that turns with axis 1), else ``back`` (KUKA's overhead area).
- **elbow**: ``up`` when the elbow (axis 3) lies above the line from the shoulder (axis 2) to
  the wrist centre, seen with the arm reaching forward; it changes exactly where the wrist
  centre crosses the line through axes 2 and 3 (KUKA's angle phi).  It depends on joint 3 only.
- **wrist**: ``noflip`` when axis 5 bends the flange the way it points down from a forearm
  reaching forward with joint 4 at zero; ``flip`` the other way (joint 4 half a turn away and
  joint 5 negated reach the same flange pose flipped).

The wrist centre is the point of axis 5 nearest axis 4 (where they meet on a spherical wrist).
``docs/export.md`` gives each vendor's encoding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.cell import DeviceModel
from .forward import link_poses


def is_arm(device: DeviceModel) -> bool:
    """Six revolute joints: an arm with a shoulder, an elbow and a wrist."""
    return device.dof == 6 and all(j.kind == "revolute" for j in device.joints)


def joint_axes(device: DeviceModel, q) -> tuple[np.ndarray, np.ndarray]:
    """Each joint's axis in the device's natural frame.

    Parameters
    ----------
    q : array_like, shape (n,) or (K, n) [rad or m]

    Returns
    -------
    points, directions : ndarray, shape (..., n, 3)
        A point on each axis [m] and its unit direction (the sense joint values turn about).
    """
    q = np.asarray(q, dtype=float)
    T = link_poses(device, q)  # (..., n, 4, 4)
    if device.convention == "standard":  # joint i turns about z of DH frame i-1 (corrected)
        base = np.broadcast_to(np.eye(4), T.shape[:-3] + (1, 4, 4))
        T = np.concatenate([base, T[..., :-1, :, :]], axis=-3)
        E = np.stack([np.eye(4) if j.correction is None else j.correction for j in device.joints])
        T = T @ E
        local = np.tile([0.0, 0.0, 1.0], (device.dof, 1))
    elif device.convention == "modified":
        local = np.tile([0.0, 0.0, 1.0], (device.dof, 1))
    else:  # a joint frame turns about its own axis through its origin
        local = np.array([np.asarray(j.axis, dtype=float) for j in device.joints])
    directions = np.einsum("...ij,...j->...i", T[..., :3, :3], local)
    return T[..., :3, 3].copy(), directions


def _nearest_on(p1, d1, p2, d2) -> np.ndarray:
    """The point of line 2 nearest line 1 (..., 3); line 2's point where they are parallel."""
    w = p1 - p2
    b = np.einsum("...i,...i->...", d1, d2)
    d = np.einsum("...i,...i->...", d1, w)
    e = np.einsum("...i,...i->...", d2, w)
    denominator = 1.0 - b**2
    t = np.where(denominator > 1e-9, (e - b * d) / np.where(denominator > 1e-9, denominator, 1), 0)
    return p2 + t[..., None] * d2


@dataclass(frozen=True)
class ArmConfigurations:
    """The configuration of each of K joint states (bool arrays, shape (K,))."""

    front: np.ndarray
    up: np.ndarray
    noflip: np.ndarray

    def names(self, k: int = 0) -> dict[str, str]:
        return {
            "shoulder": "front" if self.front[k] else "back",
            "elbow": "up" if self.up[k] else "down",
            "wrist": "noflip" if self.noflip[k] else "flip",
        }

    def matches(self, wanted: dict[str, str]) -> np.ndarray:
        """Which states have every named choice of ``wanted`` ({'elbow': 'up', ...})."""
        ok = np.ones(len(self.front), dtype=bool)
        for key, flags, yes in (
            ("shoulder", self.front, "front"),
            ("elbow", self.up, "up"),
            ("wrist", self.noflip, "noflip"),
        ):
            if key in wanted:
                ok &= flags if wanted[key] == yes else ~flags
        return ok


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-15)


def arm_configurations(device: DeviceModel, Q) -> ArmConfigurations:
    """Shoulder, elbow and wrist of joint states ``Q`` (K, 6) [rad] of a 6-axis arm."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    zero = np.zeros((1, device.dof))
    states = np.vstack([zero, Q])  # the zero pose first: it fixes "forward"
    T = link_poses(device, states)
    points, directions = joint_axes(device, states)
    W = _nearest_on(points[:, 3], directions[:, 3], points[:, 4], directions[:, 4])
    # axis 1 pointing up, from the base to the shoulder, whatever sense joint 1 turns in (KUKA's
    # A1 turns about -z)
    height = points[0, 1] @ directions[0, 0]
    z1 = directions[:, 0] * (-1.0 if height < -1e-9 else 1.0)
    # the arm's forward direction: where the wrist centre is at the zero pose, in the frame that
    # turns with joint 1, square to axis 1 (link 1's x axis if the wrist is on axis 1 there)
    T1 = T[:, 0]
    reach0 = W[0] - points[0, 0]
    reach0 = reach0 - (reach0 @ z1[0]) * z1[0]
    if np.linalg.norm(reach0) < 1e-9:
        reach0 = T1[0, :3, 0] - (T1[0, :3, 0] @ z1[0]) * z1[0]
    forward_local = np.linalg.solve(T1[0, :3, :3], reach0)
    forward = _unit(np.einsum("kij,j->ki", T1[:, :3, :3], forward_local))
    reach = W - points[:, 0]
    front = np.einsum("ki,ki->k", reach, forward) >= 0.0
    h = _unit(np.cross(z1, forward))  # square to the arm's plane
    P2, P3 = points[:, 1], points[:, 2]
    up = np.einsum("ki,ki->k", np.cross(P3 - P2, W - P2), h) > 0.0
    # the wrist: the bend about axis 5 from the forearm (axis 4, pointing away from the elbow)
    # to the tool (axis 6, pointing the way it continues the forearm at joint 5 zero), against
    # the bend that points the tool down from a forearm reaching forward with joint 4 at zero
    z4, z5, z6 = directions[:, 3], directions[:, 4], directions[:, 5]
    forearm = z4 * np.sign(np.einsum("ki,ki->k", W - P3, z4) + 1e-300)[:, None]
    straight = states.copy()
    straight[:, 4] = 0.0
    _, d5 = joint_axes(device, straight)
    along = np.sign(np.einsum("ki,ki->k", d5[:, 5], forearm) + 1e-300)
    tool = z6 * along[:, None]
    bend = np.einsum("ki,ki->k", np.cross(forearm, tool), z5)
    # with joint 4 at zero, axis 5 against the arm plane's normal h: which sense bends down
    Q4 = states.copy()
    Q4[:, 3] = 0.0
    _, d4 = joint_axes(device, Q4)
    down = np.sign(np.einsum("ki,ki->k", d4[:, 4], h) + 1e-300)
    noflip = bend * down >= 0.0
    return ArmConfigurations(front[1:], up[1:], noflip[1:])


# ------------------------------------------------------------------ the vendors' words


def as_written(axes, decimals: int, unit: str = "deg") -> np.ndarray:
    """The axis values [rad] a controller reads back from a program that writes them in
    ``unit`` ("deg" or "rad") to ``decimals`` places: what every configuration field (a sign,
    a quadrant, a turn) is taken from, so that it agrees with the joint values written beside
    it (an axis at -5.6e-14 rad is written 0, and is 0 for its quadrant, not -1)."""
    axes = np.asarray(axes, dtype=float)
    if unit == "deg":
        return np.radians(np.round(np.degrees(axes), decimals)) + 0.0  # + 0.0: no -0
    return np.round(axes, decimals) + 0.0


def abb_confdata(axes: np.ndarray, configuration: dict[str, str] | None) -> list[int]:
    """ABB's ``confdata`` [cf1, cf4, cf6, cfx] of a 6-axis joint solution (the controller's
    axis values [rad]): the quarter revolutions of axes 1, 4 and 6 (floor of angle / 90 deg);
    cfx = 4 (wrist centre behind axis 1) + 2 (behind the lower arm: elbow down) + 1 (axis 5
    negative)."""
    quarter = np.floor(np.asarray(axes)[[0, 3, 5]] / (np.pi / 2)).astype(int)
    cfx = 0
    if configuration is not None:
        cfx += 4 * (configuration["shoulder"] == "back") + 2 * (configuration["elbow"] == "down")
    cfx += int(axes[4] < 0)
    return [int(quarter[0]), int(quarter[1]), int(quarter[2]), cfx]


def kuka_status_turn(axes: np.ndarray, configuration: dict[str, str] | None) -> tuple[int, int]:
    """KUKA's Status and Turn of a joint solution (the controller's axis values [rad]).

    Status: bit 0 the wrist centre in the overhead area (behind axis 1), bit 1 A3 >= phi (the
    elbow up), bit 2 A5 <= 0.  Turn: bit i set when axis i+1 is negative.
    """
    status = 0
    if configuration is not None:
        status |= int(configuration["shoulder"] == "back") | 2 * int(configuration["elbow"] == "up")
    status |= 4 * int(axes[4] <= 0)
    turn = sum(1 << i for i, value in enumerate(np.asarray(axes)[:6]) if value < 0)
    return status, int(turn)


def fanuc_config(axes: np.ndarray, configuration: dict[str, str] | None) -> str:
    """FANUC's configuration string of a joint solution (the controller's axis values [rad]):
    'F' (J5 > 0) or 'N', 'U' (elbow up) or 'D', 'T' (wrist centre in front of J1) or 'B', then
    the turn numbers of J4, J5 and J6 (0 for -180 < angle <= 180 deg)."""
    flip = "F" if axes[4] > 0 else "N"
    elbow = "U" if configuration is None or configuration["elbow"] == "up" else "D"
    front = "T" if configuration is None or configuration["shoulder"] == "front" else "B"
    turns = [int(np.ceil((np.degrees(a) - 180.0) / 360.0)) for a in np.asarray(axes)[3:6]]
    return f"{flip} {elbow} {front}, " + ", ".join(str(t) for t in turns)


def vendor_words(vendor: str | None, axes: np.ndarray, configuration: dict[str, str]) -> str:
    """A 6-axis arm's configuration as its controller states it: KUKA's Status and Turn,
    ABB's confdata, FANUC's CONFIG string (``axes``: the controller's axis values [rad]);
    empty for a vendor without one (UR: joint targets) or none."""
    if vendor == "kuka":
        status, turn = kuka_status_turn(axes, configuration)
        return f"KUKA S {status} T {turn}"
    if vendor == "abb":
        return "ABB confdata [" + ",".join(str(c) for c in abb_confdata(axes, configuration)) + "]"
    if vendor == "fanuc":
        return f"FANUC CONFIG '{fanuc_config(axes, configuration)}'"
    return ""
