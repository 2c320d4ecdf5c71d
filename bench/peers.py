"""The peers' models, built once for every bench: the same device as rworld's, each peer in its
best ordinary setup.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rworld_cli.spatial import dh_standard  # noqa: E402


def pinocchio_model(device):
    """The device (standard DH) as a Pinocchio model: revolute-z or prismatic-z joints at DH
    frame i-1, bodies in DH frame i.

    A joint moves about or along z_{i-1}, then the fixed part Rz(theta) Tz(d) Tx(a) Rx(alpha)
    follows: for a revolute joint Rz(q) Rz(theta) = Rz(q + theta), for a prismatic one Tz(q)
    commutes with Rz(theta), so Tz(q) Rz(theta) Tz(d) = Rz(theta) Tz(q + d).
    """
    import pinocchio as pin

    if device.convention != "standard":
        raise SystemExit("this bench builds standard-DH chains only")
    model = pin.Model()
    parent = 0
    placement = pin.SE3.Identity()
    for joint, link in zip(device.joints, device.links):
        kind = pin.JointModelRZ() if joint.kind == "revolute" else pin.JointModelPZ()
        jid = model.addJoint(parent, kind, placement, joint.name)
        fixed = dh_standard(joint.a, joint.alpha, joint.d, joint.theta)
        M = pin.SE3(fixed[:3, :3], fixed[:3, 3])
        inertial = link.inertial
        model.appendBodyToJoint(jid, pin.Inertia(inertial.mass, inertial.com, inertial.inertia), M)
        placement, parent = M, jid
    tool = model.addFrame(pin.Frame("tool", parent, 0, placement, pin.FrameType.OP_FRAME))
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    return model, tool


def pinocchio_with_armature(device, gravity=(0.0, 0.0, -9.81)):
    """The Pinocchio model with the motors' reflected inertia Jm G^2 as its armature (rworld's
    planning model:
    rigid bodies + armature, no friction)."""
    model, tool = pinocchio_model(device)
    model.armature = np.array([j.armature for j in device.joints])
    model.gravity.linear = np.asarray(gravity, dtype=float)
    return model, tool


def coal_mesh(triangles: np.ndarray):
    """A body's triangles (F, 3, 3) [m] as coal's OBBRSS tree, in the body's frame."""
    import coal

    vertices, faces = np.unique(triangles.reshape(-1, 3), axis=0, return_inverse=True)
    tree = coal.BVHModelOBBRSS()
    tree.beginModel(len(triangles), len(vertices))
    tree.addVertices(vertices)
    tree.addTriangles(faces.reshape(-1, 3))
    tree.endModel()
    return tree
