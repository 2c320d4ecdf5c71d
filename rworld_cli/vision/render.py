"""Images a camera would take: the calibration boards' patterns through the lens's distortion,
the bodies in front of them, blur and pixel noise - good enough that OpenCV's detectors find the
corners where the exact projection puts them (``docs/vision.md``).

A pixel's centre ray is its undistorted direction (OpenCV's ``undistortPointsIter``, once per
camera); it meets the nearest board's plane and takes the pattern's shade there. Where the
shade changes between neighbours, a pixel is the mean of ``supersample`` x ``supersample``
rays (area sampling, the sub-pixel rays by the map's local derivative: edges fall between
pixels as a sensor integrates them). A pixel whose
centre ray reaches a board through a body (exact segment-triangle tests, for the pixels inside
the body's image, tile by tile against the triangles in each tile's cone) takes the body's
shade.
"""

from __future__ import annotations

import functools

import numpy as np

from .. import spatial
from ..geometry import sight_cone, sight_lines_hit_triangles, spheres_in_sight, triangle_spheres
from ..model.vision import BoardModel, CameraModel
from .camera import project

BLACK, WHITE, BACKGROUND, BODY = 25.0, 225.0, 110.0, 70.0
#: ChArUco prints are sampled from OpenCV's own drawing at about this many pixels a square
CHARUCO_PIXELS_PER_SQUARE = 100
#: pixels across an AprilTag in the grid's drawing (36h11: 8 cells of code and border, 15 px each)
APRILGRID_PIXELS_PER_TAG = 120


#: the renderer's occlusion test takes the pixels in tiles of this many on a side: each tile's
#: sight lines span a narrow cone, which most of a body's triangles lie outside
OCCLUSION_TILE = 32


def _hidden(origin, ends, rows, cols, triangles) -> np.ndarray:
    """Which sight lines from ``origin`` (3,) to ``ends`` (M, 3) [m], the centre rays of the
    pixels (``rows``, ``cols``), cross one of the body's ``triangles`` (K, 3, 3): tile by tile
    (:data:`OCCLUSION_TILE`), each tile's rays against the triangles in their cone only
    (``geometry.sight_cone``, ``spheres_in_sight``), then the exact shared-origin test
    (``geometry.sight_lines_hit_triangles``). (M,) bool."""
    hidden = np.zeros(len(ends), dtype=bool)
    centres, radii = triangle_spheres(triangles)
    tile = (rows // OCCLUSION_TILE) * (int(cols.max()) // OCCLUSION_TILE + 1) + (
        cols // OCCLUSION_TILE
    )
    order = np.argsort(tile, kind="stable")
    bounds = np.flatnonzero(np.diff(tile[order])) + 1
    for group in np.split(order, bounds):  # a loop over tiles, not pixels
        cone = sight_cone(origin, ends[group])
        if cone is not None:
            near = triangles[spheres_in_sight(origin, cone, centres, radii)]
        else:
            near = triangles
        if len(near):
            hidden[group] = sight_lines_hit_triangles(origin, ends[group], near)
    return hidden


@functools.lru_cache(maxsize=8)
def _pixel_rays(intrinsics: tuple, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel centre's undistorted normalised coordinates (H, W, 2) and their derivative
    along u and v (H, W, 2, 2)."""
    import cv2

    fx, fy, cx, cy = intrinsics[:4]
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    u, v = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    pts = np.stack([u.ravel(), v.ravel()], axis=1)[:, None, :]
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 1e-14)
    n = cv2.undistortPointsIter(pts, K, np.array(intrinsics[4:]), np.eye(3), K, criteria)
    n = (n.reshape(-1, 2) - K[:2, 2]) / np.diag(K)[:2]  # back from pixels to normalised
    n = n.reshape(height, width, 2)
    du = np.gradient(n, axis=1)
    dv = np.gradient(n, axis=0)
    return n, np.stack([du, dv], axis=-1)


@functools.lru_cache(maxsize=4)
def _charuco_print(board: BoardModel) -> tuple[np.ndarray, int]:
    """OpenCV's drawing of the board and its pixels a square (OpenCV's drawing refuses some
    sizes for rounding: the next size up is taken)."""
    import cv2

    from .detect import charuco_image

    for pixels in range(CHARUCO_PIXELS_PER_SQUARE, CHARUCO_PIXELS_PER_SQUARE + 50):
        try:
            return charuco_image(board, pixels).astype(float), pixels
        except cv2.error:
            continue
    raise ValueError(f"OpenCV cannot draw the ChArUco board {board.name!r}")


@functools.lru_cache(maxsize=4)
def _aprilgrid_print(board: BoardModel) -> tuple[np.ndarray, float, int]:
    """OpenCV's drawing of the grid, its pixels a metre and its white margin [px]: a tag's
    cells 15 px (36h11's 8 across a tag, its black border included: 120 px a tag)."""
    from .detect import aprilgrid_image

    pixels = APRILGRID_PIXELS_PER_TAG / board.square
    margin = int(round(float(board.spacing or 0.0) * pixels))  # a gap of white around
    return aprilgrid_image(board, pixels, margin).astype(float), pixels, margin


def _shade(board: BoardModel, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """The board's print at board coordinates [m]: NaN off the printed area."""
    s = board.square
    if board.pattern == "aprilgrid":
        img, pixels, border = _aprilgrid_print(board)
        h, w = img.shape
        with np.errstate(invalid="ignore"):
            col = np.floor(np.nan_to_num(X * pixels, nan=-1e9)).astype(np.int64) + border
            row = np.floor(np.nan_to_num(Y * pixels, nan=-1e9)).astype(np.int64) + border
        inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
        out = np.full(X.shape, np.nan)
        out[inside] = np.where(img[row[inside], col[inside]] > 127, WHITE, BLACK)
        return out
    if board.pattern == "charuco":
        img, pixels = _charuco_print(board)
        h, w = img.shape
        with np.errstate(invalid="ignore"):
            col = np.floor(np.nan_to_num(X / s * pixels, nan=-1.0)).astype(int)
            row = np.floor(np.nan_to_num(Y / s * pixels, nan=-1.0)).astype(int)
        inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
        out = np.full(X.shape, np.nan)
        out[inside] = np.where(img[row[inside], col[inside]] > 127, WHITE, BLACK)
        return out
    nx, ny = board.corner_grid
    i = np.floor(X / s)
    j = np.floor(Y / s)
    squares = (i >= -1) & (i <= nx - 1) & (j >= -1) & (j <= ny - 1)
    margin = (X >= -2 * s) & (X <= (nx + 1) * s) & (Y >= -2 * s) & (Y <= (ny + 1) * s)
    out = np.where(margin, WHITE, np.nan)
    black = squares & ((i + j) % 2 == 0)
    out[black] = BLACK
    return out


def render_view(
    camera: CameraModel,
    T_world_camera: np.ndarray,
    boards: list[tuple[BoardModel, np.ndarray]],
    occluders: list[np.ndarray],
    blur_px: float = 0.6,
    noise: float = 2.0,
    seed: int = 0,
    supersample: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """The grey image and the depth the camera would see.

    Parameters
    ----------
    boards : list of (BoardModel, T_world_board (4, 4))
    occluders : list of ndarray, shape (K, 3, 3)
        Triangles of the bodies that may stand in front of a board, in world [m].
    blur_px : float
        Sigma of a Gaussian blur [px] (a lens's point spread); 0: none.
    noise : float
        Sigma of the pixels' noise [grey levels of 255].

    Returns
    -------
    image : ndarray of uint8, shape (H, W)
    depth : ndarray of float32, shape (H, W)
        Distance along the optical axis to the board seen at each pixel's centre [m]; inf
        where no board is (a body in front of a board: the board's depth, the pixel grey).
    """
    import cv2

    W, H = camera.width, camera.height
    n, dn = _pixel_rays(tuple(camera.intrinsics.tolist()), W, H)
    faced = []  # the boards whose print faces the camera, with T_board_camera's R and o
    for board, T_world_board in boards:
        T_board_camera = spatial.invert_transform(T_world_board) @ T_world_camera
        if T_board_camera[2, 3] < 0:  # the print faces -z: from its back it is not drawn
            faced.append((board, T_board_camera[:3, :3], T_board_camera[:3, 3]))

    def shade_at(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The nearest board's shade along rays (x, y, 1) and the depth there (BACKGROUND and
        inf where none)."""
        value = np.full(x.shape, BACKGROUND)
        depth = np.full(x.shape, np.inf)
        for board, R, o in faced:
            dz = R[2, 0] * x + R[2, 1] * y + R[2, 2]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = -o[2] / dz  # the ray (x, y, 1) t meets the board's plane
            X = o[0] + t * (R[0, 0] * x + R[0, 1] * y + R[0, 2])
            Y = o[1] + t * (R[1, 0] * x + R[1, 1] * y + R[1, 2])
            shade = _shade(board, X, Y)
            near = np.isfinite(shade) & (t > 0) & (t < depth)
            value[near] = shade[near]
            depth[near] = t[near]
        return value, depth

    value, depth = shade_at(n[..., 0], n[..., 1])
    # area sampling where the shade changes: the pixels at an edge, and their neighbours
    edge = np.zeros((H, W), dtype=bool)
    for axis in (0, 1):
        step = np.abs(np.diff(value, axis=axis)) > 0.5
        if axis == 0:
            edge[1:] |= step
            edge[:-1] |= step
        else:
            edge[:, 1:] |= step
            edge[:, :-1] |= step
    r, c = np.nonzero(edge)
    if len(r):
        offsets = (np.arange(supersample) + 0.5) / supersample - 0.5
        a, b = (g.ravel() for g in np.meshgrid(offsets, offsets))
        x = n[r, c, 0][:, None] + dn[r, c, 0, 0][:, None] * a + dn[r, c, 0, 1][:, None] * b
        y = n[r, c, 1][:, None] + dn[r, c, 1, 0][:, None] * a + dn[r, c, 1, 1][:, None] * b
        value[r, c] = shade_at(x, y)[0].mean(axis=1)
    seen = np.isfinite(depth)
    # bodies in front of a board: the centre rays of the pixels inside each body's image
    if occluders and seen.any():
        origin = T_world_camera[:3, 3]
        T_camera_world = spatial.invert_transform(T_world_camera)
        rows, cols = np.nonzero(seen)
        for triangles in occluders:
            # a body wholly behind every board's print (the table it lies on) hides none: the
            # sight line from the camera, in front of the print, stays in front of it
            behind = True
            for board, T_world_board in boards:
                T_board_world = spatial.invert_transform(T_world_board)
                z = triangles.reshape(-1, 3) @ T_board_world[2, :3] + T_board_world[2, 3]
                behind &= bool(np.all(z >= -1e-9))
            if behind:
                continue
            pc = (triangles.reshape(-1, 3) @ T_camera_world[:3, :3].T) + T_camera_world[:3, 3]
            if np.all(pc[:, 2] <= 0):
                continue
            uv = project(camera.intrinsics, np.where(pc[:, 2:3] > 1e-6, pc, np.nan))
            if np.any(pc[:, 2] <= 1e-6):  # a body around the lens: test every board pixel
                pick = np.ones(len(rows), dtype=bool)
            else:
                lo, hi = np.nanmin(uv, axis=0) - 2, np.nanmax(uv, axis=0) + 2
                pick = (cols >= lo[0]) & (cols <= hi[0]) & (rows >= lo[1]) & (rows <= hi[1])
            if not pick.any():
                continue
            r, c = rows[pick], cols[pick]
            d = np.stack([n[r, c, 0], n[r, c, 1], np.ones(len(r))], axis=1) * depth[r, c][:, None]
            ends = d @ T_world_camera[:3, :3].T + origin
            # the sight lines that pass the body's bounding sphere at all
            points = triangles.reshape(-1, 3)
            centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
            radius = float(np.linalg.norm(points - centre, axis=1).max())
            seg = ends - origin
            s = np.clip(
                (centre - origin) @ seg.T / np.maximum(np.sum(seg * seg, axis=1), 1e-300), 0, 1
            )
            near = np.linalg.norm(origin + s[:, None] * seg - centre, axis=1) <= radius
            if not near.any():
                continue
            r, c, ends = r[near], c[near], ends[near]
            hidden = _hidden(origin, ends, r, c, triangles)
            value[r[hidden], c[hidden]] = BODY
    if blur_px > 0:
        value = cv2.GaussianBlur(value, (0, 0), blur_px)
    if noise > 0:
        value = value + np.random.default_rng(seed).normal(0.0, noise, value.shape)
    return np.clip(np.rint(value), 0, 255).astype(np.uint8), depth.astype(np.float32)
