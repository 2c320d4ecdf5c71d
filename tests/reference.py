"""Build rworld models from the reference JSON files in tests/data/reference/dynamics."""

from __future__ import annotations

import json

import numpy as np

from rworld_cli.dynamics import Payload
from rworld_cli.kinematics.jacobian import ToolMount
from rworld_cli.model.cell import DeviceModel, Inertial, Joint, JointLimits, Link
from tests.conftest import REFERENCE


def load_reference(name: str) -> dict:
    return json.loads((REFERENCE / "dynamics" / name).read_text())


def device_from_reference(model: dict) -> DeviceModel:
    """The reference model as a DeviceModel: DH rows, link mass properties, no motors or
    friction.
    """
    joints, links = [], []
    for i, row in enumerate(model["links"]):
        prismatic = row["joint"] != "R"
        offset = row["offset"] or 0.0
        d = offset if prismatic else (row["d"] or 0.0)
        theta = (row["theta"] or 0.0) if prismatic else offset
        joints.append(
            Joint(
                f"j{i + 1}",
                "prismatic" if prismatic else "revolute",
                row["a"],
                row["alpha"],
                d,
                theta,
                JointLimits(),
            )
        )
        links.append(
            Link(
                f"link{i + 1}",
                Inertial(row["m"], np.array(row["r"], float), np.array(row["I"], float)),
                None,
            )
        )
    return DeviceModel(
        model["name"],
        model["dh_convention"],
        tuple(joints),
        tuple(links),
        (),
        np.zeros(len(joints)),
    )


def mount_and_payload(model: dict) -> tuple[ToolMount, Payload | None]:
    mount = ToolMount(len(model["links"]), np.array(model["tool"], float))
    p = model.get("payload")
    payload = Payload(p["mass"], np.array(p["com"], float), np.array(p["I"], float)) if p else None
    return mount, payload


def states(model: dict, key: str) -> np.ndarray:
    return np.array([s[key] for s in model["states"]], dtype=float)
