"""The compiled GJK (``collision/compiled.py``) against the numpy GJK it mirrors.

The oracle tests of ``test_convex.py`` run on both; here the two are compared with each other on
the pairs where rounding matters most (boxes and cylinders, many of them touching), and the
compiled kernel's speed path is checked to be the one taken.
"""

from __future__ import annotations

import numpy as np
import pytest

from rworld_cli.collision import convex as cv
from tests.collision.test_convex import random_poses


@pytest.mark.parametrize("kinds", [("box", "box"), ("box", "cylinder"), ("cylinder", "cylinder")])
def test_compiled_and_numpy_gjk_agree(kinds):
    """The two implementations of one algorithm: the same distances (to the convergence
    tolerance), decisions and iteration counts up to rounding; valid closest points on both."""
    from rworld_cli import kernels
    from rworld_cli.collision.compiled import gjk

    if kernels.backend() != "llvm":
        pytest.skip("no compiled kernels on this machine")
    n = 3000
    Ta, Tb = random_poses(n, 21, 0.05), random_poses(n, 22)

    def make(kind, T, size):
        return (
            cv.boxes(T, size * np.array([0.5, 1.0, 1.5]))
            if kind == "box"
            else (cv.cylinders(T, size * 0.6, size * 1.4))
        )

    a, b = make(kinds[0], Ta, 0.1), make(kinds[1], Tb, 0.08)
    assert gjk(a, b, cv.MAX_ITERATIONS) is not None
    compiled = cv.distance(a, b)
    numpy_ = cv._distances(a, b, *cv._gjk_numpy(a, b, cv.MAX_ITERATIONS))
    assert np.abs(compiled.distance - numpy_.distance).max() <= 1e-9
    assert np.array_equal(compiled.overlap, numpy_.overlap)
    assert 0 < compiled.overlap.sum() < n  # both kinds of answer are exercised
    # rounding can stop a curved pair's linear convergence an iteration or more sooner or later;
    # most pairs take the same steps, and as many on average
    assert np.mean(compiled.iterations == numpy_.iterations) >= 0.85
    assert abs(compiled.iterations.mean() / numpy_.iterations.mean() - 1.0) <= 0.05
    far = ~compiled.overlap
    gap = np.linalg.norm(compiled.point_a[far] - compiled.point_b[far], axis=1)
    assert np.abs(gap - compiled.distance[far]).max() <= 1e-9
