"""The report's proposed accuracy and sensitivity analysis (section 4.1.3.3).

Two ways to get T from planes known in the object frame (A) and measured in
world (Q), Q = A T^-1 (Appendix 1):

* constrained - R by the SVD of M = Q A^T with orthogonality enforced
  (eq. 13, with a reflection guard), t by least squares (4.1.3.2);
* unconstrained - T^-1 by plain least squares on all 16 elements (4.1.3.3),
  "no assurance on the orthogonality of R".

Accuracy: random T, 5 random planes, both methods on exact data.
Sensitivity: each plane coefficient scaled by (1 + e), e uniform in 0.1 % .. 1 %.
Compared: relative element errors |t_ij - t~_ij| / |t_ij| and ||R^T R - I||.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import spatial
from .solve import kabsch


def constrained(A: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """T from plane rows A (object) and Q (world), (n, 4) each, with R orthogonal."""
    nA, nQ = A[:, :3], Q[:, :3]
    R = kabsch(
        nQ / np.linalg.norm(nQ, axis=1, keepdims=True),
        nA / np.linalg.norm(nA, axis=1, keepdims=True),
    )
    # q_c = n_q . t + a_c with the rows scaled alike: (Q[:, :3]) t = Q[:, 3] - A[:, 3] * |n_q| /
    # |n_a|
    scale = np.linalg.norm(nQ, axis=1) / np.linalg.norm(nA, axis=1)
    t = np.linalg.lstsq(-nQ, Q[:, 3] - A[:, 3] * scale, rcond=None)[0]
    return spatial.make_transform(R, t)


def unconstrained(A: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """T from plain least squares on Q = A T^-1 (all 16 elements free)."""
    Tinv = np.linalg.lstsq(A, Q, rcond=None)[0]
    return np.linalg.inv(Tinv)


@dataclass
class AnalysisRow:
    method: str
    median_element_error: float
    max_element_error: float
    median_orthogonality: float
    max_orthogonality: float


def _planes(rng, n: int) -> np.ndarray:
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return np.column_stack([normals, rng.uniform(-1, 1, n)])


BLOCK = 500
"""Trials per task.  Block ``i`` draws from ``SeedSequence(seed, spawn_key=(i,))``, so a seed
gives the same trials, and the same figures, on one process, a pool or a cluster."""


def blocks(trials: int) -> list[int]:
    """The trial counts of the blocks ``trials`` is split into (:data:`BLOCK` each, the last
    what is left)."""
    return [min(BLOCK, trials - start) for start in range(0, trials, BLOCK)]


def analysis_block(
    kind: str, trials: int, planes: int, seed: int, index: int
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Block ``index`` of the comparison: per method, each trial's median relative element
    error and ||R^T R - I||, ``(trials,)`` arrays each.

    A trial: a random T, ``planes`` random planes A (unit normals, offsets in -1 .. 1 m),
    Q = A T^-1 - exact (accuracy), or each coefficient times (1 + e), |e| uniform in
    0.1 .. 1 % with a random sign (sensitivity) - and T computed back by both methods.
    """
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))
    errors: dict[str, tuple[list, list]] = {"constrained": ([], []), "unconstrained": ([], [])}
    for _ in range(trials):
        T = spatial.make_transform(
            spatial.rpy_to_matrix(rng.uniform(-np.pi, np.pi, 3)), rng.uniform(-1, 1, 3)
        )
        A = _planes(rng, planes)
        Q = A @ np.linalg.inv(T)
        if kind == "sensitivity":
            eps = rng.uniform(0.001, 0.01, Q.shape) * rng.choice([-1, 1], Q.shape)
            Q = Q * (1 + eps)
        for name, method in (("constrained", constrained), ("unconstrained", unconstrained)):
            Te = method(A, Q)
            mask = np.abs(T[:3]) > 1e-9
            rel = np.abs(T[:3][mask] - Te[:3][mask]) / np.abs(T[:3][mask])
            R = Te[:3, :3]
            errors[name][0].append(np.median(rel))
            errors[name][1].append(np.linalg.norm(R.T @ R - np.eye(3)))
    return {name: (np.array(e), np.array(o)) for name, (e, o) in errors.items()}


def summarize(
    parts: list[dict[str, tuple[np.ndarray, np.ndarray]]],
) -> tuple[list[AnalysisRow], dict[str, tuple[np.ndarray, np.ndarray]]]:
    """Rows per method (median and largest of both figures) over the blocks, in block order,
    and the joined per-trial samples."""
    samples = {
        name: (
            np.concatenate([p[name][0] for p in parts]),
            np.concatenate([p[name][1] for p in parts]),
        )
        for name in ("constrained", "unconstrained")
    }
    rows = [
        AnalysisRow(
            name, float(np.median(e)), float(np.max(e)), float(np.median(o)), float(np.max(o))
        )
        for name, (e, o) in samples.items()
    ]
    return rows, samples


def run_analysis(
    kind: str, trials: int = 1000, planes: int = 5, seed: int = 0
) -> tuple[list[AnalysisRow], dict[str, tuple[np.ndarray, np.ndarray]]]:
    """Accuracy (exact data) or sensitivity (coefficients off by 0.1 .. 1 %) of both methods
    over random trials, in this process (``api.analyze_calibration`` spreads the blocks over
    an executor, with the same result)."""
    return summarize(
        [analysis_block(kind, n, planes, seed, i) for i, n in enumerate(blocks(trials))]
    )
