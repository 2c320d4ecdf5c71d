"""Tactile pads against solids: rworld beside trimesh's CollisionManager and python-fcl, in one run.

Run:  .venv/bin/pip install -e ".[bench]" && .venv/bin/python bench/sensing.py [--repeat 3]

A pad of n x n cells (80 x 80 x 6 mm) is placed partly buried in two solids:
an icosphere (r = 50 mm, 1280 triangles) and a 100 x 100 x 60 mm box with a
40 mm through-hole (non-convex).  Every method answers "which cells
interfere with the solid"; ground truth is the exact overlap volume of each
cell with the solid (manifold3d), a cell counting when it exceeds 1e-12 of
its own volume.  Times are the query only (collision managers built
beforehand), best of --repeat; throughput in cells per second.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rworld_cli import spatial  # noqa: E402
from rworld_cli.geometry import grid_interference  # noqa: E402
from rworld_cli.sensing.exact import holed_box, icosphere, truth_grid  # noqa: E402

PAD = np.array([0.08, 0.08, 0.006])
POSES = {  # T_solid_pad: the pad tilted and cutting into the solid
    "icosphere": spatial.make_transform(
        spatial.rpy_to_matrix([0.25, -0.15, 0.1]), [0.004, -0.006, 0.02]
    ),
    "holed_box": spatial.make_transform(
        spatial.rpy_to_matrix([0.12, 0.08, 0.3]), [0.005, 0.003, -0.025]
    ),
}


def best(fn, repeat):
    out, t = None, np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        t = min(t, time.perf_counter() - t0)
    return out, t


def cell_transforms(n: int, T_solid_pad: np.ndarray):
    d = PAD / np.array([n, n, 1])
    lo = np.array([-PAD[0] / 2, -PAD[1] / 2, 0.0])
    out = []
    for idx in np.ndindex(n, n, 1):
        T = np.eye(4)
        T[:3, 3] = lo + (np.array(idx) + 0.5) * d
        out.append(T_solid_pad @ T)
    return out, d


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[8, 16, 32, 64])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    try:
        import fcl
        import trimesh
    except ImportError:
        raise SystemExit(
            "python-fcl is not installed: .venv/bin/pip install -e '.[bench]'"
        ) from None

    print(
        f"{'solid':10s} {'pad':>6s} {'cells':>6s} {'truth':>6s} | {'rworld cells/s':>15s} "
        f"{'wrong':>5s} | "
        f"{'fcl cells/s':>12s} {'wrong':>5s} | {'trimesh cells/s':>16s} {'wrong':>5s} | "
        f"{'rworld/fcl':>10s}"
    )
    for solid_name, make in (("icosphere", icosphere), ("holed_box", holed_box)):
        vertices, faces, manifold = make()
        T_solid_pad = POSES[solid_name]
        T_pad_solid = np.linalg.inv(T_solid_pad)
        tri_pad = (vertices @ T_pad_solid[:3, :3].T + T_pad_solid[:3, 3])[faces]
        bvh = fcl.BVHModel()
        bvh.beginModel(len(vertices), len(faces))
        bvh.addSubModel(vertices, faces)
        bvh.endModel()
        solid_obj = fcl.CollisionObject(bvh, fcl.Transform())
        mesh = trimesh.Trimesh(vertices, faces, process=False)
        for n in args.sizes:
            cells = n * n
            truth = truth_grid(PAD, (n, n, 1), manifold.transform(T_pad_solid[:3, :].tolist()))
            ours, t_ours = best(
                lambda: grid_interference(PAD, (n, n, 1), tri_pad, tolerance=1e-9), args.repeat
            )
            wrong_ours = int((ours != truth).sum())

            transforms, d = cell_transforms(n, T_solid_pad)
            geoms = [
                fcl.Box(*d) for _ in transforms
            ]  # contacts name geometries: keep them to map back
            boxes = [
                fcl.CollisionObject(g, fcl.Transform(T[:3, :3], T[:3, 3]))
                for g, T in zip(geoms, transforms)
            ]
            index = {id(g): i for i, g in enumerate(geoms)}
            manager = fcl.DynamicAABBTreeCollisionManager()
            manager.registerObjects(boxes)
            manager.setup()

            def fcl_query():
                data = fcl.CollisionData(
                    request=fcl.CollisionRequest(num_max_contacts=10 * cells, enable_contact=True)
                )
                manager.collide(solid_obj, data, fcl.defaultCollisionCallback)
                hit = np.zeros((n, n, 1), dtype=bool)
                for contact in data.result.contacts:
                    for geom in (contact.o1, contact.o2):
                        k = index.get(id(geom))
                        if k is not None:
                            hit[np.unravel_index(k, (n, n, 1))] = True
                return hit

            fcl_hit, t_fcl = best(fcl_query, args.repeat)
            wrong_fcl = int((fcl_hit != truth).sum())

            cm = trimesh.collision.CollisionManager()
            cm.add_object("solid", mesh)
            box_mesh = trimesh.creation.box(extents=d)
            for k, T in enumerate(transforms):
                cm.add_object(str(k), box_mesh, transform=T)

            def trimesh_query():
                _, pairs = cm.in_collision_internal(return_names=True)
                hit = np.zeros((n, n, 1), dtype=bool)
                for a, b in pairs:
                    other = b if a == "solid" else a if b == "solid" else None
                    if other is not None:
                        hit[np.unravel_index(int(other), (n, n, 1))] = True
                return hit

            tm_hit, t_tm = best(trimesh_query, args.repeat)
            wrong_tm = int((tm_hit != truth).sum())
            print(
                f"{solid_name:10s} {n:>3d}x{n:<2d} {cells:6d} {int(truth.sum()):6d} | "
                f"{cells / t_ours:15,.0f} {wrong_ours:5d} | "
                f"{cells / t_fcl:12,.0f} {wrong_fcl:5d} | {cells / t_tm:16,.0f} {wrong_tm:5d} | "
                f"{(cells / t_ours) / (cells / t_fcl):10.2f}"
            )
    print(
        "\nrworld/fcl = throughput ratio (above 1: rworld faster); 'truth' = cells that interfere "
        "(overlap volume)"
    )


if __name__ == "__main__":
    main()
