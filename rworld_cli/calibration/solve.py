"""Natural frames from measured features (C1, C2), and auxiliary frames from one feature (C3-C13).

Natural frames (calibration report, section 4):

* **closed form** first.  C2 (features with orientation information):
  direction pairs - oriented plane normals, oriented line directions -
  give ``R`` by the report's eq. 13 (``M = Q A^T``, orthogonality enforced by
  the SVD, here with a reflection guard), then ``t`` by least squares on
  the features' linear equations (section 4.1.3.2).  C1 (no orientation):
  intersection points of the features (section 4.2.2: plane triples, line x
  plane, closest points of two lines, circle centres, points; a circle's axis
  counts as a line) registered with the same SVD.
* **maximum likelihood** next: the pose that minimises the probe points'
  distances to the nominal features (scipy ``least_squares``), so the pose
  error is at the noise floor; its Jacobian gives the covariance and the
  predicted standard errors, and - scaled to be dimensionless - the
  conditioning figure that decides whether the features determine the
  frame at all (the report's sufficiency rules of 4.1.1, checked numerically).

Auxiliary frames: one feature imposes a condition on the frame's nominal
pose in its owner's calibrated frame; the smallest rotation (and
translation) that satisfies it is applied.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from .. import spatial
from ..model.cell import Feature
from ..model.measurements import Probing
from .fit import FeatureFit

NO_PROBING = Probing()

ARCSEC = np.pi / (180 * 3600)
REFUSE_CONDITION = 1e6  # above this the features leave a motion of the frame undetermined
WARN_CONDITION = 30.0  # above this a motion is weakly determined (a good set scores about 5-10)


@dataclass
class FrameSolution:
    """The calibrated pose of one frame and how well it is known.

    Attributes
    ----------
    T_world : ndarray, shape (4, 4)
        The calibrated pose (world).
    closed_form : ndarray, shape (4, 4) or None
        The report's closed-form pose, before refinement (natural frames).
    covariance : ndarray, shape (6, 6) or None
        Of (rotation vector [rad], translation [m]) in world axes.
    sigma_translation, sigma_rotation : ndarray, shape (3,) or None
        Predicted standard errors [m], [rad] along / about world x, y, z.
    residual_rms : float
        Probe points' distances to the nominal features at the solution [m].
    condition : float
        Dimensionless conditioning of the pose (1 best; above 1e6 not determined).
    """

    frame: str
    code: str
    determined: bool
    T_world: np.ndarray
    T_nominal: np.ndarray
    closed_form: np.ndarray | None = None
    covariance: np.ndarray | None = None
    sigma_translation: np.ndarray | None = None
    sigma_rotation: np.ndarray | None = None
    residual_rms: float = 0.0
    condition: float = 1.0
    reason: str = ""
    warnings: list[str] = field(default_factory=list)

    @property
    def correction(self) -> tuple[float, float]:
        """(translation [m], rotation angle [rad]) from nominal to calibrated."""
        delta = np.linalg.inv(self.T_nominal) @ self.T_world
        return float(np.linalg.norm(delta[:3, 3])), float(
            np.linalg.norm(spatial.rotation_vector(delta[:3, :3]))
        )


def kabsch(world: np.ndarray, nominal: np.ndarray) -> np.ndarray:
    """Rotation R minimising sum |world_i - R nominal_i|^2, a proper rotation (reflection guard)."""
    return kabsch_checked(world, nominal)[0]


def kabsch_checked(world: np.ndarray, nominal: np.ndarray) -> tuple[np.ndarray, bool]:
    """(R, mirrored): ``mirrored`` when the best orthogonal fit was a reflection and the guard
    took the nearest rotation.
    """
    M = world.T @ nominal  # the report's M = Q A^T
    U, s, Vt = np.linalg.svd(M)
    mirrored = np.linalg.det(U @ Vt) < 0 and s[-1] > 1e-9 * s[0]
    D = np.diag([1.0, 1.0, -1.0 if np.linalg.det(U @ Vt) < 0 else 1.0])
    return U @ D @ Vt, bool(mirrored)


# --------------------------------------------------------------------------- closed form


def _intersections(
    features: list[Feature], fits: dict[str, FeatureFit]
) -> tuple[np.ndarray, np.ndarray]:
    """Corresponding points (nominal, world) from points, circle centres and feature
    intersections (a circle's axis counts as a line through its centre).
    """
    nom, wld = [], []
    for f in features:
        fit = fits[f.name]
        if f.kind in ("point", "circle"):
            nom.append(f.point), wld.append(fit.point)
    planes = [f for f in features if f.kind == "plane"]
    lines = [f for f in features if f.kind in ("line", "circle")]  # a circle's axis is a line
    for a, b, c in combinations(planes, 3):
        N = np.stack([a.direction, b.direction, c.direction])
        if abs(np.linalg.det(N)) > 0.1:
            Nw = np.stack([fits[x.name].direction for x in (a, b, c)])
            nom.append(np.linalg.solve(N, [x.direction @ x.point for x in (a, b, c)]))
            wld.append(
                np.linalg.solve(
                    Nw, [fits[x.name].direction @ fits[x.name].point for x in (a, b, c)]
                )
            )
    for line in lines:
        for plane in planes:
            if abs(line.direction @ plane.direction) > 0.1:
                for src, out, L, P in (
                    (line, nom, line, plane),
                    (None, wld, fits[line.name], fits[plane.name]),
                ):
                    d, p, n, q = L.direction, L.point, P.direction, P.point
                    out.append(p + d * ((q - p) @ n) / (d @ n))
    for a, b in combinations(lines, 2):
        if np.linalg.norm(np.cross(a.direction, b.direction)) > 0.1:
            for out, A, B in ((nom, a, b), (wld, fits[a.name], fits[b.name])):
                d1, d2, w0 = A.direction, B.direction, A.point - B.point
                aa, bb, cc, dd, ee = d1 @ d1, d1 @ d2, d2 @ d2, d1 @ w0, d2 @ w0
                den = aa * cc - bb * bb
                s, u = (bb * ee - cc * dd) / den, (aa * ee - bb * dd) / den
                out.append(0.5 * ((A.point + s * d1) + (B.point + u * d2)))
    return np.array(nom).reshape(-1, 3), np.array(wld).reshape(-1, 3)


MIRROR = (
    "the data fit a mirror image of the nominal features best (a reflection, not a "
    "rotation): check which feature is which"
)


def _oriented_form(features: list[Feature], fits: dict[str, FeatureFit]):
    """Eq. 13 from oriented directions (plane normals with their 'above' side, lines in
    probing order, circles' axes) and t from the features' linear equations; None when short."""
    pairs = [
        (fits[f.name].direction, f.direction)
        for f in features
        if f.kind in ("plane", "line", "circle")
        and fits[f.name].oriented
        and not fits[f.name].axis_only
    ]
    if len(pairs) >= 2:
        W, A = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
        if np.linalg.matrix_rank(A, tol=0.05) >= 2:
            R, mirrored = kabsch_checked(W, A)
            rows, rhs = [], []
            for f in features:
                fit = fits[f.name]
                if f.kind == "plane":
                    n = R @ f.direction
                    rows.append(n[None]), rhs.append([n @ fit.point - f.direction @ f.point])
                elif f.kind == "line" or fit.axis_only:  # a wall: its axis, as a line
                    d = R @ f.direction if fit.axis_only else fit.direction
                    P = np.eye(3) - np.outer(d, d)
                    rows.append(P), rhs.append(P @ (fit.point - R @ f.point))
                else:
                    rows.append(np.eye(3)), rhs.append(fit.point - R @ f.point)
            Aeq, beq = np.vstack(rows), np.concatenate(rhs)
            if np.linalg.matrix_rank(Aeq, tol=1e-6) == 3:
                t = np.linalg.lstsq(Aeq, beq, rcond=None)[0]
                return spatial.make_transform(R, t), "closed form (oriented directions, eq. 13)" + (
                    f"; {MIRROR}" if mirrored else ""
                )
    return None


def closed_form(
    code: str, features: list[Feature], fits: dict[str, FeatureFit]
) -> tuple[np.ndarray | None, str]:
    """The report's closed-form pose, or (None, why not); ``how`` ends with the mirror warning
    when it applies.
    """
    if code == "C2":
        oriented = _oriented_form(features, fits)
        if oriented is not None:
            return oriented
        # fall through to the points when orientation information is short
    nominal, world = _intersections(features, fits)
    if len(nominal) >= 3:
        centered = nominal - nominal.mean(axis=0)
        s = np.linalg.svd(centered, compute_uv=False)
        if s[1] > 1e-3 * s[0]:
            R, mirrored = kabsch_checked(world - world.mean(axis=0), centered)
            t = world.mean(axis=0) - R @ nominal.mean(axis=0)
            return spatial.make_transform(
                R, t
            ), f"closed form ({len(nominal)} intersection points)" + (
                f"; {MIRROR}" if mirrored else ""
            )
    if code == "C2":
        return (
            None,
            "too few oriented directions or non-collinear intersection points for the closed form",
        )
    oriented = _oriented_form(features, fits)  # C1 whose measurements happen to be oriented
    if oriented is not None:
        return oriented
    return (  # C1 with no orientation information: only points can start it
        None,
        f"the features give {len(nominal)} intersection point(s) (points, circle centres, plane "
        "triples, line or circle axis x plane, line pairs), not 3 non-collinear ones, for the "
        "closed form",
    )


# --------------------------------------------------------------------------- maximum likelihood


def _residuals(
    features: list[Feature], fits: dict[str, FeatureFit], probing: dict[str, Probing], T: np.ndarray
) -> np.ndarray:
    """Probe points' deviations from the nominal features under pose T (object -> world)."""
    R, t = T[:3, :3], T[:3, 3]
    out = []
    for f in features:
        x = (fits[f.name].points - t) @ R  # into the object frame
        how = probing.get(f.name, NO_PROBING)
        rp = how.radius
        if f.kind == "plane":
            out.append((x - f.point) @ f.direction - rp)
        elif f.kind == "line" and how.offset is not None:
            # a ball touched the edge: its centre lies the radius from the line
            v = x - f.point
            out.append(np.linalg.norm(v - np.outer(v @ f.direction, f.direction), axis=1) - rp)
        elif f.kind == "line":
            e1, e2 = _perpendicular_basis(f.direction)  # two independent residuals per point
            v = x - f.point
            out.append(np.stack([v @ e1, v @ e2], axis=1).ravel())
        elif f.kind == "circle":
            v = x - f.point
            axial = v @ f.direction
            radial = np.linalg.norm(v - np.outer(axial, f.direction), axis=1)
            if how.depth is None:  # probed at the rim: in its plane too
                out.append(axial)
            out.append(radial - (f.radius + rp if how.boss else f.radius - rp))
        else:
            out.append((x - f.point).ravel())
    return np.concatenate(out)


def _perpendicular_basis(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e1 = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1)


def residual_widths(features: list[Feature], probing: dict[str, Probing]) -> dict[str, int]:
    """Residuals per probe point of each feature (see :func:`_residuals`)."""
    out = {}
    for f in features:
        how = probing.get(f.name, NO_PROBING)
        if f.kind == "line":
            out[f.name] = 1 if how.offset is not None else 2
        elif f.kind == "circle":
            out[f.name] = 1 if how.depth is not None else 2
        else:
            out[f.name] = {"plane": 1, "point": 3}[f.kind]
    return out


def point_distances(
    features: list[Feature], fits: dict[str, FeatureFit], probing: dict[str, Probing], T: np.ndarray
) -> np.ndarray:
    """Each probe point's distance from its nominal feature under pose T [m]."""
    r = _residuals(features, fits, probing, T)
    widths = residual_widths(features, probing)
    out, k = [], 0
    for f in features:
        n = fits[f.name].n_points
        width = widths[f.name]
        block = r[k : k + n * width]
        k += n * width
        if f.kind == "circle" and width == 2:  # axial values first, then radial
            out.append(np.hypot(block[:n], block[n:]))
        else:
            out.append(np.linalg.norm(block.reshape(n, width), axis=1))
    return np.concatenate(out)


def _pose(p: np.ndarray, T0: np.ndarray) -> np.ndarray:
    """T0 turned by the rotation vector p[:3] (world axes) and shifted by p[3:]."""
    return spatial.make_transform(_rotvec_matrix(p[:3]) @ T0[:3, :3], T0[:3, 3] + p[3:])


def _rotvec_matrix(w: np.ndarray) -> np.ndarray:
    angle = np.linalg.norm(w)
    if angle < 1e-15:
        return np.eye(3)
    k = w / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _jacobian(features, fits, probing, T: np.ndarray, h: float = 1e-7) -> np.ndarray:
    r0 = _residuals(features, fits, probing, T)
    J = np.empty((len(r0), 6))
    for k in range(6):
        dp = np.zeros(6)
        dp[k] = h
        J[:, k] = (
            _residuals(features, fits, probing, _pose(dp, T))
            - _residuals(features, fits, probing, _pose(-dp, T))
        ) / (2 * h)
    return J


def _describe_motion(v: np.ndarray, scale: float) -> str:
    rot, trans = v[:3] / scale, v[3:]
    rotation = np.linalg.norm(rot) * scale >= np.linalg.norm(trans)
    axis = rot / np.linalg.norm(rot) if rotation else trans / np.linalg.norm(trans)
    axis = np.round(axis, 2) + 0.0  # + 0.0: no "-0.00" for a component that rounds to zero
    what = "a rotation about" if rotation else "a translation along"
    return f"{what} ({axis[0]:.2f}, {axis[1]:.2f}, {axis[2]:.2f})"


def solve_natural(
    frame: str,
    code: str,
    features: list[Feature],
    fits: dict[str, FeatureFit],
    probing: dict[str, Probing],
    T_nominal: np.ndarray,
    sigma: float | None = None,
) -> FrameSolution:
    """Calibrate a natural frame from its measured features.

    Parameters
    ----------
    features : list of Feature
        Nominal features, in the object's frame.
    fits : dict
        Feature name -> FeatureFit (world) with the raw points.
    probing : dict
        Feature name -> :class:`~rworld_cli.model.measurements.Probing` to compensate.
    T_nominal : ndarray, shape (4, 4)
        The nominal pose (world), the start when no closed form exists.
    sigma : float, optional
        Known probing noise [m]; default: estimated from the residuals.
    """
    from scipy.optimize import least_squares

    warnings: list[str] = []
    if code == "C2":
        unoriented = [
            f.name for f in features if f.kind in ("plane", "line") and not fits[f.name].oriented
        ]
        if unoriented:
            warnings.append(
                f"no orientation information for {', '.join(unoriented)} (C2 wants a plane's "
                "'above' point, a line's probing order)"
            )
    T_closed, how = closed_form(code, features, fits)
    if MIRROR in how:
        warnings.append(MIRROR)
    T0 = T_closed if T_closed is not None else T_nominal
    if T_closed is None:
        warnings.append(f"{how}; refined from the nominal pose")
    points = np.concatenate([fits[f.name].points for f in features])
    scale = max(float(np.sqrt(((points - points.mean(axis=0)) ** 2).sum(axis=1).mean())), 1e-6)
    J = _jacobian(features, fits, probing, T0)
    Jn = J.copy()
    Jn[:, :3] /= (
        scale  # dimensionless: rotations as the displacement they cause at the points' scale
    )
    _, s, Vt = np.linalg.svd(Jn, full_matrices=False)
    condition = float(s[0] / s[-1]) if s[-1] > 0 else np.inf
    if len(J) < 6 or condition > REFUSE_CONDITION:
        motion = _describe_motion(Vt[-1], scale)
        return FrameSolution(
            frame,
            code,
            False,
            T0,
            T_nominal,
            T_closed,
            condition=condition,
            warnings=warnings,
            reason=f"the features leave {motion} undetermined (condition number {condition:.3g})",
        )
    if condition > WARN_CONDITION:
        warnings.append(
            f"weakly determined: condition number {condition:.3g} "
            f"({_describe_motion(Vt[-1], scale)} is least constrained)"
        )
    result = least_squares(
        lambda p: _residuals(features, fits, probing, _pose(p, T0)),
        np.zeros(6),
        method="lm",
        x_scale=np.r_[np.full(3, 1.0 / scale), np.ones(3)],
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
    )
    T = _pose(result.x, T0)
    r = _residuals(features, fits, probing, T)
    J = _jacobian(features, fits, probing, T)
    dof = max(len(r) - 6, 1)
    var = sigma**2 if sigma else float(r @ r) / dof
    covariance = var * np.linalg.inv(J.T @ J)
    distances = point_distances(features, fits, probing, T)
    return FrameSolution(
        frame,
        code,
        True,
        T,
        T_nominal,
        T_closed,
        covariance,
        np.sqrt(np.diag(covariance)[3:]),
        np.sqrt(np.diag(covariance)[:3]),
        float(np.sqrt(np.mean(distances**2))),
        condition,
        "",
        warnings,
    )


# --------------------------------------------------------------------------- auxiliary frames


def _align(R: np.ndarray, axis: int, target: np.ndarray) -> np.ndarray:
    """Smallest rotation of frame R bringing its ``axis`` parallel to ``target`` (either sense)."""
    a = R[:, axis]
    b = target / np.linalg.norm(target)
    if a @ b < 0:
        b = -b
    v = np.cross(a, b)
    s, c = np.linalg.norm(v), a @ b
    if s < 1e-15:
        return R
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]]) / s
    angle = np.arctan2(s, c)
    return (np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K) @ R


AXIS = {"x": 0, "y": 1, "z": 2}


def apply_condition(
    code: str, T_owner_frame: np.ndarray, kind: str, point: np.ndarray, direction: np.ndarray | None
) -> np.ndarray:
    """The frame moved (least) to satisfy condition ``code`` for a feature given in the owner's
    frame.

    C3 origin on the line/plane; C4-C6 the x/y/z axis normal to the plane;
    C7-C9 the xy/xz/yz plane perpendicular to the line/plane; C10-C12 that
    plane parallel to the plane; C13 origin at the circle's centre, xy plane
    in the circle's plane.
    """
    R, o = T_owner_frame[:3, :3].copy(), T_owner_frame[:3, 3].copy()
    n = None if direction is None else direction / np.linalg.norm(direction)
    if code == "C3":
        if kind == "plane":
            o = o - ((o - point) @ n) * n
        else:
            o = point + ((o - point) @ n) * n
    elif code in ("C4", "C5", "C6"):
        R = _align(R, "xyz".index({"C4": "x", "C5": "y", "C6": "z"}[code]), n)
    elif code in ("C7", "C8", "C9"):
        normal_axis = {"C7": 2, "C8": 1, "C9": 0}[code]  # the normal of the xy / xz / yz plane
        if kind == "line":
            R = _align(
                R, normal_axis, n
            )  # the plane is perpendicular to the line: its normal along it
        else:
            a = R[:, normal_axis]
            inplane = (
                a - (a @ n) * n
            )  # the plane is perpendicular to the plane: its normal lies in it
            if np.linalg.norm(inplane) > 1e-12:
                R = _align(R, normal_axis, inplane)
    elif code in ("C10", "C11", "C12"):
        R = _align(R, {"C10": 2, "C11": 1, "C12": 0}[code], n)
    elif code == "C13":
        R = _align(R, 2, n)
        o = point.copy()
    return spatial.make_transform(R, o)
