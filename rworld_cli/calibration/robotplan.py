"""Pose selection for robot calibration (``rworld plan-robot-calibration``): which joint states
to measure so that the identification is best determined.

Candidates are random joint states within the limits, kept when the robot collides with
nothing there.  Each candidate's rows of the scaled identification Jacobian (the error model of
:mod:`.robot`), projected on the combinations the candidates can identify at all, are its
information ``G``.  Poses are added one at a time: D-optimal until the information matrix ``M``
is whole (``log det(I + G M^-1 G^T)``, a 3x3 determinant per candidate), then the pose that
lowers the predicted error at the validation poses most (I-optimal: the trace drop
``tr((I + G M^-1 G^T)^-1 G M^-1 S M^-1 G^T)`` by Woodbury), and two passes of exchanges.  The
predicted error of the calibrated model at a pose is ``sigma^2 G_v M^-1 G_v^T``.
"""

from __future__ import annotations

import numpy as np

from .robot import RobotModel


def _predicted(G_set: np.ndarray, G_check: np.ndarray, sigma: float) -> float:
    M = np.einsum("kai,kaj->ij", G_set, G_set)
    try:
        cov = sigma**2 * np.linalg.inv(M)
    except np.linalg.LinAlgError:
        return float("inf")
    per = np.einsum("kai,ij,kaj->k", G_check, cov, G_check)
    return float(np.sqrt(np.mean(per)))


def select_poses(
    model: RobotModel,
    candidates: np.ndarray,
    count: int,
    sigma: float,
    seed: int = 0,
    passes: int = 10,
) -> tuple[np.ndarray, dict]:
    """Greedy D-optimal choice of ``count`` states among ``candidates`` (M, n).

    Returns
    -------
    chosen : ndarray of int, shape (count,)
        Indices into ``candidates``.
    figures : dict
        ``predicted``, ``random_same``, ``random_double`` [m], ``identifiable``.
    """
    rng = np.random.default_rng(seed)
    M = len(candidates)
    check = rng.permutation(M)[: min(M, 500)]  # validation poses for the predictions
    J = model.jacobian(np.zeros(len(model.names)), candidates) * model.scales
    _, s, Vt = np.linalg.svd(J, full_matrices=False)
    rank = int(np.sum(s > s[0] * 1e-6))
    basis = Vt[:rank].T
    G = (J @ basis).reshape(M, 3, rank)
    info = np.eye(rank) * 1e-9 * float(np.einsum("kai,kai->", G, G)) / M
    chosen: list[int] = []
    free = np.ones(M, dtype=bool)
    S = np.einsum("kai,kaj->ij", G[check], G[check]) / len(check)  # the validation poses
    for k in range(count):
        inv = np.linalg.inv(info)
        B = np.einsum("kai,ij,kbj->kab", G, inv, G) + np.eye(3)
        if len(chosen) * 3 < rank + 3:  # until the information is whole: D-optimal
            score = np.linalg.slogdet(B)[1]
        else:  # then the pose that lowers the predicted error at the validation poses most
            H = inv @ S @ inv
            X = np.einsum("kai,ij,kbj->kab", G, H, G)
            score = np.einsum("kaa->k", np.linalg.solve(B, X))
        score = np.where(free, score, -np.inf)
        best = int(np.argmax(score))
        chosen.append(best)
        free[best] = False
        info = info + G[best].T @ G[best]
    # exchanges: a chosen pose swapped for the candidate that lowers the prediction most
    for _ in range(passes):
        improved = False
        for slot in range(len(chosen)):
            rest = info - G[chosen[slot]].T @ G[chosen[slot]]
            try:
                inv = np.linalg.inv(rest)
            except np.linalg.LinAlgError:
                continue
            B = np.einsum("kai,ij,kbj->kab", G, inv, G) + np.eye(3)
            X = np.einsum("kai,ij,kbj->kab", G, inv @ S @ inv, G)
            score = np.einsum("kaa->k", np.linalg.solve(B, X))
            score[~free] = -np.inf
            score[chosen[slot]] = np.einsum(
                "aa->", np.linalg.solve(B[chosen[slot]], X[chosen[slot]])
            )
            best = int(np.argmax(score))
            if best != chosen[slot] and score[best] > score[chosen[slot]] * (1 + 1e-9):
                free[chosen[slot]], free[best] = True, False
                chosen[slot] = best
                improved = True
            info = rest + G[chosen[slot]].T @ G[chosen[slot]]
        if not improved:
            break
    G_check = G[check]
    figures = {
        "predicted": _predicted(G[chosen], G_check, sigma),
        "identifiable": rank,
    }
    for key, size in (("random_same", count), ("random_double", 2 * count)):
        draws = [
            _predicted(G[rng.choice(M, min(size, M), replace=False)], G_check, sigma)
            for _ in range(20)
        ]
        figures[key] = float(np.median(draws))
    return np.array(chosen), figures
