"""The box trees' walks compiled to machine code, called from numpy: the separating-axis
bound of node pairs (:func:`box_gap`), the descent to a leaf pair (:func:`descend`), the
collision-only walk (:func:`touching`), the walk with its leaves measured (:func:`contacts`)
and the check of many pairs of bodies at many states (:func:`free_states`, :func:`pair_rows`).

Why: the numpy bound makes some fifty temporary arrays of the batch's size (3 x 3 products,
the nine edge axes), so a node pair costs about a microsecond; the search of a vendor's link
against a fixture visits thousands per state.  Compiled, each is one LLVM function with every
value in a register.  The IR is written in :mod:`~rworld_cli.collision.bvh_ir` and
:mod:`~rworld_cli.collision.free_states_ir` on :mod:`~rworld_cli.collision.kernel_ir`'s builder;
this module compiles it (:func:`rworld_cli.kernels.compile_ir`: llvmlite, cached on disk;
``RWORLD_KERNELS=numpy`` or a failed compile fall back to the numpy code, which the kernels
equal to rounding: ``tests/collision/test_bvh.py``) and passes the arrays.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from .. import kernels
from . import bvh_ir, free_states_ir, kernel_ir
from .bvh_ir import WITNESS
from .free_states_ir import BODY_WORDS

__all__ = ["BODY_WORDS", "WITNESS", "box_gap", "contacts", "descend", "free_states", "touching"]


_FUNCTION: list = []  # [ctypes function or None], built once per process


def _functions():
    """The module's ctypes functions - the bound, the collision-only walk, the descent, the
    walk with its leaves measured, the free-only check, the same for rows of their own - or
    six Nones (kernels off, or the compile failed); one module, compiled once per process and
    cached on disk."""
    if not _FUNCTION:
        from . import compiled

        # every file whose code makes the module names it (the leaves' GJK is compiled.py's)
        files = (__file__, kernel_ir.__file__, bvh_ir.__file__, free_states_ir.__file__)
        source = "".join(Path(name).read_text() for name in (*files, compiled.__file__))
        digest = hashlib.sha256(source.encode()).hexdigest()[:20]
        gjk_symbol = f"rworld_contacts_gjk_{digest}"
        contacts_symbol = f"rworld_contacts_{digest}"
        # (symbol, signature, IR text) in the order of the tuple returned
        table = [
            ("box_gap", bvh_ir.BOX_GAP, bvh_ir.box_gap_ir),
            ("touching", bvh_ir.TOUCHING, bvh_ir.touching_ir),
            ("descend", bvh_ir.DESCEND, bvh_ir.descend_ir),
            ("contacts", bvh_ir.CONTACTS, lambda s: bvh_ir.contacts_ir(s, gjk_symbol)),
            (
                "free_states",
                free_states_ir.FREE_STATES,
                lambda s: free_states_ir.free_states_ir(s, contacts_symbol),
            ),
            (
                "pair_rows",
                free_states_ir.PAIR_ROWS,
                lambda s: free_states_ir.free_states_ir(s, contacts_symbol, rows=True),
            ),
        ]
        symbols = [f"rworld_{name}_{digest}" for name, _, _ in table]

        def build() -> str:
            import llvmlite.binding as llvm

            module = llvm.parse_assembly(compiled.gjk_ir(gjk_symbol, local=True))
            for symbol, (_, _, text) in zip(symbols, table):
                module.link_in(llvm.parse_assembly(text(symbol)))
            return str(module)

        addresses = kernels.compile_ir("box trees", build, symbols, source)
        if addresses is None:
            _FUNCTION.extend([None] * len(table))
        else:
            for address, (_, signature, _) in zip(addresses, table):
                _FUNCTION.append(kernel_ir.prototype(signature)(address))
    return tuple(_FUNCTION)


def pair_rows(rows, poses, table, spheres, boxes, limits, deep, max_iterations: int):
    """:func:`.free_states_ir` with ``rows``: each row (R, 3) int64 - a state (a row of
    ``poses`` (M, B, 12)) and two bodies of ``table`` - walked up to its own limit (R,):
    (status (R,), nearest (R,)), or None (no compiled kernel)."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    limits = np.ascontiguousarray(limits, dtype=float)
    head = (len(rows), rows.ctypes.data)
    return _fused_call(
        5,
        head,
        poses,
        table,
        spheres,
        boxes,
        limits.ctypes.data,
        deep,
        max_iterations,
        (len(rows),),
    )


def free_states(pairs, poses, table, spheres, boxes, limit, deep, max_iterations: int):
    """:func:`.free_states_ir` on ``pairs`` (P, 2) of bodies whose rows of ``table`` (B,
    :data:`BODY_WORDS`) int64 (:func:`body_table`), ``spheres`` (B, 4) and ``boxes`` (B, 9)
    describe them, at
    ``poses`` (N, B, 12): (status (N, P), nearest (N, P)), or None (no compiled kernel)."""
    pairs = np.ascontiguousarray(pairs, dtype=np.int64)
    head = (len(poses), len(pairs), pairs.ctypes.data)
    return _fused_call(
        4,
        head,
        poses,
        table,
        spheres,
        boxes,
        float(limit),
        deep,
        max_iterations,
        (len(poses), len(pairs)),
    )


def _fused_call(which, head, poses, table, spheres, boxes, limit, deep, max_iterations, shape):
    """One call of :func:`.free_states_ir`'s kernel ``which`` (4: states, 5: rows): ``head``
    its leading arguments, ``limit`` its limit (a double, or the address of the rows'), the
    outputs of ``shape``; the caller holds every array whose address it passes (the kernel
    reads raw addresses)."""
    if kernels.backend() != "llvm":
        return None
    function = _functions()[which]
    if function is None:
        return None
    poses = np.ascontiguousarray(poses, dtype=float)
    status = np.zeros(shape, dtype=np.int64)
    nearest = np.full(shape, np.inf)
    witness = np.zeros(WITNESS)
    if status.size:
        function(
            *head,
            poses.shape[1],
            poses.ctypes.data,
            table.ctypes.data,
            spheres.ctypes.data,
            boxes.ctypes.data,
            limit,
            float(deep),
            int(max_iterations),
            status.ctypes.data,
            nearest.ctypes.data,
            witness.ctypes.data,
        )
    return status, nearest


def body_table(sides: list) -> np.ndarray:
    """The rows (B, :data:`BODY_WORDS`) int64 of :func:`.free_states_ir` for bodies' prepared
    sides (:func:`walk_side`, held by the caller as long as the table is used)."""
    return np.array([[*side[1], *side[2]] for side in sides], dtype=np.int64).reshape(
        -1, BODY_WORDS
    )


def walk_side(tree, leaves) -> tuple:
    """A body's tree and leaf table as :func:`contacts` takes them (contiguous, typed; kept
    by the caller, so that one pair's call does not convert them again): ``leaves`` =
    (table (R, V, 3), neighbours (R, V, D) int64 or None: scanned, pose (12,): the table's
    frame in the tree's, R's rows then t, estimate: (axes (R, 3, 3), centres (R, 3)) in the
    table's frame as :func:`rworld_cli.collision.convex.candidate_depth` takes them (complete:
    exact depths), None, or ``"cylinder"``: the table is one cylinder, ``[[[radius, half
    length, 0]]]``, on the pose's z axis);
    the tree's leaf ``item`` is the table's row ``item``, a polytope; an inner node's is
    passed as minus its number of leaves (:func:`.contacts_ir`)."""
    table, neighbours, pose, estimate = leaves
    arrays = [np.ascontiguousarray(x, dtype=float) for x in (tree.center, tree.half, tree.axes)]
    # an inner node's item: minus the number of leaves below it (the walk's leaf-against-box
    # bound is tried only above enough of them); a leaf's: its row
    item = np.where(tree.item >= 0, tree.item, -_leaves_below(tree))
    arrays += [np.ascontiguousarray(x, dtype=np.int64) for x in (tree.left, tree.right, item)]
    table = np.ascontiguousarray(table, dtype=float)
    degree = 0 if neighbours is None else int(np.shape(neighbours)[2])
    neighbours = (
        np.full((1, 1, 1), -2, dtype=np.int64)
        if neighbours is None
        else np.ascontiguousarray(neighbours, dtype=np.int64)
    )
    pose = np.ascontiguousarray(pose, dtype=float)
    # each row's axes (3 rows of 3) and centre, in the table's frame, for the depth estimate
    # (flag 1); none (a flag of 0, one zero row) where the exact query is to decide; a flag of
    # 2: the table's one row is a cylinder's (radius, half length, 0), its axis the pose's z
    flag = 0 if estimate is None else 2 if isinstance(estimate, str) else 1
    axes, centres = (np.zeros((1, 9)), np.zeros((1, 3))) if flag != 1 else estimate
    axes = np.ascontiguousarray(np.reshape(axes, (-1, 9)), dtype=float)
    centres = np.ascontiguousarray(np.reshape(centres, (-1, 3)), dtype=float)
    held = (*arrays, table, neighbours, pose, axes, centres)
    addresses = [x.ctypes.data for x in arrays]
    leaf = [table.shape[1], table.ctypes.data, neighbours.ctypes.data, degree, pose.ctypes.data]
    leaf += [flag, axes.ctypes.data, centres.ctypes.data]
    return held, addresses, leaf


def _leaves_below(tree) -> np.ndarray:
    """The number of leaves under each node of ``tree`` (N,) int64: every leaf climbs to the
    root at once, one level a step."""
    N = len(tree.item)
    parent = np.full(N, -1, dtype=np.int64)
    inner = np.flatnonzero(tree.item < 0)
    parent[tree.left[inner]] = inner
    parent[tree.right[inner]] = inner
    count = np.zeros(N, dtype=np.int64)
    at = np.flatnonzero(tree.item >= 0)
    while len(at):
        np.add.at(count, at, 1)
        at = parent[at]
        at = at[at >= 0]
    return count


def contacts(side_a, side_b, R, t, limit, deep: float, max_iterations: int):
    """For each of K states ``T_a_b`` = (``R`` (K, 3, 3), ``t`` (K, 3)): whether a leaf pair of
    the two bodies (:func:`walk_side` each) within ``limit`` [m] (one for all states, or (K,))
    overlaps, deeper than ``deep``
    by GJK's bound, and the least distance of those that do not (:func:`.contacts_ir`):
    (status (K,) int, nearest (K,), witness (K, :data:`WITNESS`): the nearest pair's closest
    points in a's frame, its leaves, and where shallow overlaps were found their deepest's
    depth or NaN), or None when no compiled kernel is available or a tree is too deep for its
    stack."""
    if kernels.backend() != "llvm":
        return None
    function = _functions()[3]
    if function is None:
        return None
    # every array is held by a name until the call returns: the kernel reads raw addresses
    Rc, tc = np.ascontiguousarray(R, dtype=float), np.ascontiguousarray(t, dtype=float)
    K = len(Rc)
    status = np.zeros(K, dtype=np.int64)
    nearest = np.full(K, np.inf)
    witness = np.full((K, WITNESS), -1.0)
    if not K:
        return status, nearest, witness
    limits = np.ascontiguousarray(np.broadcast_to(np.asarray(limit, dtype=float), (K,)))
    function(
        K,
        limits.ctypes.data,
        float(deep),
        Rc.ctypes.data,
        tc.ctypes.data,
        *side_a[1],
        *side_b[1],
        *side_a[2],
        *side_b[2],
        int(max_iterations),
        status.ctypes.data,
        nearest.ctypes.data,
        witness.ctypes.data,
    )
    if status[0] < 0:  # a tree deeper than the kernel's stack: the caller's search answers
        return None
    return status, nearest, witness


def _tree_arrays(tree_a, tree_b) -> list[np.ndarray]:
    """Both trees' arrays in the kernels' argument order (each tree: centre, half, axes as
    float64; left, right, item as int64), contiguous; held by the caller until the call
    returns (the kernels read raw addresses)."""
    out = []
    for tree in (tree_a, tree_b):
        out += [np.ascontiguousarray(x, dtype=float) for x in (tree.center, tree.half, tree.axes)]
        out += [np.ascontiguousarray(x, dtype=np.int64) for x in (tree.left, tree.right, tree.item)]
    return out


def descend(tree_a, tree_b, k, a, b, R, t):
    """The descent of :func:`rworld_cli.collision.bvh.candidates`, compiled: each node pair
    (``a[q]``, ``b[q]``) at state ``k[q]`` of ``R`` (K, 3, 3), ``t`` (K, 3) followed down to a
    leaf pair; (leaf nodes of a, of b), or None when no compiled kernel is available."""
    if kernels.backend() != "llvm":
        return None
    function = _functions()[2]
    if function is None:
        return None
    # every array is held by a name until the call returns: the kernel reads raw addresses
    ka = np.ascontiguousarray(k, dtype=np.int64)
    na = np.array(a, dtype=np.int64)  # copies: the kernel writes the leaves over them
    nb = np.array(b, dtype=np.int64)
    Rc, tc = np.ascontiguousarray(R, dtype=float), np.ascontiguousarray(t, dtype=float)
    trees = _tree_arrays(tree_a, tree_b)
    function(
        len(ka),
        ka.ctypes.data,
        na.ctypes.data,
        nb.ctypes.data,
        Rc.ctypes.data,
        tc.ctypes.data,
        *[x.ctypes.data for x in trees],
    )
    return na, nb


def touching(tree_a, tree_b, R: np.ndarray, t: np.ndarray, limit: float):
    """The leaf pairs of two trees whose boxes' bound stays within ``limit`` [m] all the way
    down, at each of K states ``T_a_b`` = (``R`` (K, 3, 3), ``t`` (K, 3)): (k, leaf_a, leaf_b)
    int arrays sorted by state, as :func:`rworld_cli.collision.bvh.candidates` finds them
    without its refinements (a collision test); None when no compiled kernel is available."""
    if kernels.backend() != "llvm":
        return None
    walk = _functions()[1]
    if walk is None:
        return None
    # every array is held by a name until the call returns: the kernel reads raw addresses
    Rc, tc = np.ascontiguousarray(R, dtype=float), np.ascontiguousarray(t, dtype=float)
    trees = _tree_arrays(tree_a, tree_b)
    capacity = max(64, 8 * len(Rc))
    while True:
        out = [np.empty(capacity, dtype=np.int64) for _ in range(3)]
        count = np.zeros(1, dtype=np.int64)
        walk(
            len(Rc),
            float(limit),
            Rc.ctypes.data,
            tc.ctypes.data,
            *[x.ctypes.data for x in trees],
            capacity,
            *[x.ctypes.data for x in out],
            count.ctypes.data,
        )
        found = int(count[0])
        if found < 0:  # a tree deeper than the kernel's stack: the numpy search answers
            return None
        if found <= capacity:
            return out[0][:found], out[1][:found], out[2][:found]
        capacity = found


def box_gap(tree_a, a, tree_b, b, k, R, t) -> np.ndarray | None:
    """:func:`rworld_cli.collision.bvh.box_gap` of node pairs ``a[q]``, ``b[q]`` at states
    ``k[q]`` of ``R`` (K, 3, 3), ``t`` (K, 3), compiled; None when no kernel is available."""
    if kernels.backend() != "llvm":
        return None
    function = _functions()[0]
    if function is None:
        return None
    out = np.empty(len(a))
    if not len(a):
        return out
    # every array is held by a name until the call returns: the kernel reads raw addresses
    index = [np.ascontiguousarray(x, dtype=np.int64) for x in (a, b, k)]
    floats = [
        np.ascontiguousarray(x, dtype=float)
        for x in (
            tree_a.center,
            tree_a.half,
            tree_a.axes,
            tree_b.center,
            tree_b.half,
            tree_b.axes,
            R,
            t,
        )
    ]
    function(
        len(a), *[x.ctypes.data for x in index], *[x.ctypes.data for x in floats], out.ctypes.data
    )
    return out
