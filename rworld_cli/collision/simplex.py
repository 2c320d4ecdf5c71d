"""What both GJK implementations share (``convex``'s numpy one and ``compiled``'s machine code):
the stopping tolerances and the simplex faces searched for the nearest point.  Below both, so
that neither imports the other to read them."""

from __future__ import annotations

from itertools import combinations

RELATIVE_TOLERANCE = 1e-10
ABSOLUTE_TOLERANCE = 1e-11  # [m]

# faces of a simplex that contain its newest point (the nearest point always involves it),
# by simplex size; the newest point is the last
FACES = {
    n: [s for k in range(1, n + 1) for s in combinations(range(n), k) if n - 1 in s]
    for n in (1, 2, 3, 4)
}
