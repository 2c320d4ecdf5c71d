"""Camera calibration (``rworld calibrate-camera``) against OpenCV's hand-eye methods on real
data, against the Cramer-Rao bound on simulated views, and its times.

Run:  .venv/bin/python bench/vision.py [--seeds 80] [--bootstrap 200] [--images DIR]

1. Real data (``--only real``: 1, 1b, 1c): Ali et al.'s KUKA eye-in-hand sets
   (``tests/data/vision/kuka1``, ``kuka2``, ``kuka3``) and Tabb and Ahmad Yousef's Denso set
   (``tabb1``): the corners OpenCV found in the shipped images. A fixed split: every 4th view
   held out from the 4th (7). For rworld's two models and each of OpenCV's five hand-eye
   methods (Tsai, Park, Horaud, Andreff, Daniilidis; the board then from the views' mean
   through the robot) and two robot-world methods (Shah, Li), on the same detections (OpenCV's
   intrinsics from ``calibrateCamera`` on the fitted views): the held-out views' corners
   predicted through the robot (board in base, flange pose, camera in flange, intrinsics; not
   each view's own PnP), rms px; AX = XB over the held-out views' pairs (each view's PnP with
   the method's intrinsics), rms deg and mm; and over the four splits (held out from the 1st,
   2nd, 3rd, 4th view), how often each of rworld's models is ahead of the best of OpenCV's
   seven on each figure (the flange-error model predicts the held-out views where it expects
   the robot: its errors' correlation over the poses, ``docs/vision.md``). 1c: the rendered
   sets with their truth (``cs_synthetic1``-``3``): each method's camera-in-flange error.
2. The bootstrap over the fitted views (resampled with replacement; for the flange-error
   model also weighted: a view drawn k times fitted once, its corners counted k times) and
   the delete-d jackknife (37 % of the views left out, no view twice): the camera-in-flange
   pose's spread against the sigma rworld reports and the pixel-noise one (``--only
   spread``: this section alone, on kuka2 or ``--set``'s real set; ``--model`` one model of
   the robot's poses).
3. Simulated cells with a known truth (``--seeds``, 20 views of a 9 x 6 board, 0.3 px noise):
   each parameter's error spread against the Cramer-Rao bound of pixel noise, and the sigma
   rworld reports against the spread.
4. Times: corners found per 1920 x 1200 image (the two vendored images, or every image of
   ``--images DIR``, e.g. the data set's BMPs); a 30-view calibration.
5. Rendering; 6. planning the views (``--only rendering``, ``--only planning``): the planned
   views' predicted camera-pose error against random usable views', the loops on rendered
   images. 6b (``--only planning --vendors``): the same on seven vendor robots, both set-ups,
   without and with the candidates drawn around the first choice (``--refine``).
7e. The flange-error model on a vendor robot off its model (``--only flange-errors``, up to
   3 ``--truths``): Yaskawa's GP12 (``tests/data/probe_robots/gp12``), 40 planned views
   emulated through the truth, the nominal flanges reported: held-out rms of both models and
   the camera's place relative to the board at the held-out joints through the nominal robot
   and the written poses, against the truth.
7f. Views planned for the one estimate (``--only plan-with-robot``, ``--truths N``):
   ``plan-views --with-robot`` on the test cell's UR5 and Yaskawa's GP12
   (``tests/data/probe_robots/gp12``), 8 to 40 views: the camera-to-board pose's predicted
   error at the robot's poses against the views chosen for the camera alone from the same
   candidates and against random ones; then the prediction against N truths of the UR5 and
   N/2 of the GP12 (joint frames off by 0.5 mm / 0.05 deg, 12 planned views emulated through
   each with 0.1 px, ``calibrate-camera --with-robot``): the error at the plan's poses, rms
   over the truths.
8. AprilTag grids (``--only aprilgrid``): the test cell with a 6 x 4 grid of 40 mm tags for its
   chessboard, the wrist camera at 8 planned views and the overhead camera, rendered with 0.6
   and 1.2 px of blur; each tag's corners by OpenCV's refinements and by rworld's edge fit
   against the exact projection: rms, largest, and the mean pull toward the tag's centre.
7. The robot's own errors from the camera (``--only robot``, ``--truths N``): the test cell's
   UR5 off its DH table (a pose before every row, 0.5 mm and 0.05 deg sigma), 40 planned views
   emulated through the true robot with 0.1 px of noise, the controller's nominal flanges in
   the capture file: the exact-robot fit against the two steps (``--write-robot-observations``,
   ``calibrate-robot``, ``--through-robot``): held-out (every 4th) rms and the camera's place
   relative to the board at the held-out joints, against the truth. ``--vendors``: the same on
   robots from their vendors' packages (``tests/vision/camera_cells.py``), their joint frames
   off by a small pose each (0.5 mm, 0.05 deg sigma): held-out rms. Each row also gives the
   one estimate (``--with-robot``: camera, board and the robot's joint frames in one bundle
   adjustment, from the nominal robot).
7c. The one estimate's sigma (``--only robot-spread --seeds N``): one truth of section 7, 40
   planned views, N draws of the 0.1 px noise; the camera's place relative to the board at 5
   of the views (gauge-free: the board's pose and joint 1's errors are one to the camera) -
   the sigma the estimate predicts (its joint covariance through the place's Jacobian)
   against the spread over the draws, and the rms error against the truth.
7d. The one estimate on both set-ups (``--only robot-setups``): DENSO's VS060 and Kinova's Gen3
   from their vendors' packages, the camera on the TCP or fixed beside the robot with a board
   on the TCP (``camera_cell``), joint frames off by 0.5 mm / 0.05 deg, 40 planned views, 0.1
   px: held-out rms, exact robot against the one estimate.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench.machine import cpu_model  # noqa: E402
from rworld_cli.model.vision import BoardModel  # noqa: E402

DATA = REPO / "tests" / "data" / "vision" / "kuka2"


def _views(folder: Path):
    from rworld_cli.api.vision import capture_views
    from rworld_cli.schema.captures import read_captures

    return capture_views(read_captures(str(folder / "captures.yaml")))


def _kuka2():
    return _views(DATA)


#: the methods compared: rworld's two models and OpenCV's five hand-eye and two robot-world ones
HAND_EYE = ("TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS")
ROBOT_WORLD = ("SHAH", "LI")


def _estimates(train) -> list[tuple]:
    """(label, camera, X, Z, ms, rworld's result or None) for every method on the fitted
    views ``train``."""
    import cv2

    from rworld_cli.vision import calibrate as vc

    rows = []
    for label, flange_errors in (("rworld, exact robot", False), ("rworld, flange errors", True)):
        t0 = time.perf_counter()
        r = vc.calibrate_views(train, flange_errors=flange_errors)
        ms = (time.perf_counter() - t0) * 1000
        rows.append((label, r.camera, r.T_mount_camera, r.T_holder_board, ms, r))
    t0 = time.perf_counter()
    camera, C = vc.intrinsics_start(train, use_guess=False)
    ms_intr = (time.perf_counter() - t0) * 1000
    for name in HAND_EYE + ROBOT_WORLD:
        t0 = time.perf_counter()
        if name in HAND_EYE:
            X, Z = vc.hand_eye_start(train, C, getattr(cv2, f"CALIB_HAND_EYE_{name}"))
            label = f"OpenCV hand-eye {name.title()}"
        else:
            X, Z = vc.robot_world_start(
                train, C, getattr(cv2, f"CALIB_ROBOT_WORLD_HAND_EYE_{name}")
            )
            label = f"OpenCV robot-world {name.title()}"
        rows.append((label, camera, X, Z, ms_intr + (time.perf_counter() - t0) * 1000, None))
    return rows


def _figures(test, camera, X, Z) -> np.ndarray:
    """Held-out rms [px], AX = XB rotation [deg] and translation [mm] on the views ``test``."""
    from rworld_cli.vision import calibrate as vc

    rms = vc.reprojection_rms(camera, X, Z, test)
    dr, dt = vc.axxb_residuals(X, test, vc.view_poses(test, camera))
    return np.array([rms, np.degrees(dr), dt * 1000])


def real_data(folder: Path, splits: bool = True) -> tuple:
    """Section 1 on one real set: the fixed split's table, and over the four splits (every 4th
    view held out from the 1st, 2nd, 3rd or 4th) which method is ahead on each figure."""
    views = _views(folder)
    index = np.arange(len(views.names))
    what = ("held-out rms", "AX=XB rotation", "AX=XB translation")
    wins = np.zeros((2, 3), dtype=int)
    table = {}
    for start in (3, 0, 1, 2) if splits else (3,):
        held = index[start::4]
        fit = np.setdiff1d(index, held)
        train, test = views.subset(fit), views.subset(held)
        rows = _estimates(train)
        # rworld's flange-error model predicts the held-out views where it expects the robot
        # (the errors' correlation over the poses); the others through the robot as given
        results = {
            label: _figures(test if r is None else r.robot_views(test), cam, X, Z)
            for label, cam, X, Z, _ms, r in rows
        }
        best = np.min([v for k, v in results.items() if not k.startswith("rworld")], axis=0)
        wins += np.array([results["rworld, exact robot"] < best,
                          results["rworld, flange errors"] < best])  # fmt: skip
        if start != 3:
            continue
        table = {label: r for label, _c, _X, _Z, _ms, r in rows if r is not None}
        print(
            f"1. real data: {folder.relative_to(REPO)}: {len(fit)} views fitted, {len(held)} held "
            "out (every 4th from the 4th)"
        )
        print(
            f"   {'method':<26} {'held-out rms px':>15} {'AX=XB deg':>10} {'AX=XB mm':>9} {'ms':>7}"
        )
        for label, _cam, _X, _Z, ms, _r in rows:
            rms, dr, dt = results[label]
            print(f"   {label:<26} {rms:15.3f} {dr:10.4f} {dt:9.3f} {ms:7.0f}")
        theirs = {k: v for k, v in results.items() if not k.startswith("rworld")}
        for k, unit in enumerate(("px", "deg", "mm")):
            name = min(theirs, key=lambda n: theirs[n][k])
            ours = {n: results[n][k] for n in results if n.startswith("rworld")}
            print(
                f"   {what[k]}: best OpenCV {name} {theirs[name][k]:.4f} {unit}; "
                + "; ".join(
                    f"{n} {v:.4f} (theirs / ours {theirs[name][k] / v:.2f})"
                    for n, v in ours.items()
                )  # fmt: skip
            )
        ours, fe = table["rworld, exact robot"], table["rworld, flange errors"]
        camera = rows[2][1]
        print(
            f"   flange errors found: {np.degrees(fe.flange_sigma[0]):.4f} deg, "
            f"{fe.flange_sigma[1] * 1000:.3f} mm a view, correlated with the nearest view's by "
            f"{fe.flange_field.neighbour_correlation:.2f} ({fe.flange_field.share:.2f} over "
            f"{fe.flange_field.length * 1000:.0f} mm, a turn as {fe.flange_field.lever:.2f} "
            f"m/rad); the corners' noise {fe.sigma0:.3f} px; "
            f"fx {ours.camera.fx:.2f} (exact robot), {fe.camera.fx:.2f} (flange errors), "
            f"{camera.fx:.2f} (calibrateCamera)"
        )
        out = (views, train, ours, fe)
    if splits:
        print(
            "   over the 4 splits, ahead of the best of OpenCV's seven (held-out rms, AX=XB deg, "
            f"mm): exact robot {' '.join(map(str, wins[0]))} of 4; flange errors "
            f"{' '.join(map(str, wins[1]))} of 4"
        )
    return out


def synthetic_truth() -> None:
    """Section 1c: Ali et al.'s rendered sets with their ground truth (the camera 180 deg about
    the flange's x, at its origin; the board's pose in the base), all views fitted: each
    method's camera-in-flange error against the truth (given to 4 decimals: 0.05 mm, 0.003
    deg), and the board's for rworld."""
    from rworld_cli import spatial
    from tests.vision.test_calibrate import _ground_truth

    print(
        "1c. rendered sets with a known truth (Ali et al.'s CS_synthetic_1-3), every view fitted:"
    )
    for number in (1, 2, 3):
        folder = DATA.parent / f"cs_synthetic{number}"
        truth = _ground_truth(folder / "GroundTruth.txt")
        views = _views(folder)
        rows = _estimates(views)
        T = truth["hand2eye"]
        errors = {}
        for label, _cam, X, _Z, _ms, _r in rows:
            turn = spatial.rotation_vector(X[:3, :3] @ T[:3, :3].T)
            errors[label] = (
                np.linalg.norm(X[:3, 3] - T[:3, 3]) * 1000,
                np.degrees(np.linalg.norm(turn)),
            )
        theirs = {k: v for k, v in errors.items() if not k.startswith("rworld")}
        best_p = min(theirs, key=lambda n: theirs[n][0])
        best_r = min(theirs, key=lambda n: theirs[n][1])
        ours = rows[0][5]
        Zt = truth["base2grid"]
        dz = np.linalg.norm(ours.T_holder_board[:3, 3] - Zt[:3, 3]) * 1000
        rz = np.degrees(
            np.linalg.norm(spatial.rotation_vector(ours.T_holder_board[:3, :3] @ Zt[:3, :3].T))
        )
        print(
            f"   set {number} ({len(views.names)} views, corners' rms {ours.rms:.3f} px): "
            "camera in flange, position / rotation error: "
            + "; ".join(
                f"{k} {v[0]:.3f} mm / {v[1]:.4f} deg"
                for k, v in errors.items()
                if k.startswith("rworld")
            )  # fmt: skip
            + f"; best OpenCV {best_p.split()[-1]} {theirs[best_p][0]:.3f} mm, "
            f"{best_r.split()[-1]} {theirs[best_r][1]:.4f} deg; the board (7.6 m away) {dz:.3f} "
            f"mm / {rz:.4f} deg"
        )
        print(
            "      every method: "
            + ", ".join(f"{k.split()[-1]} {v[0]:.2f} mm {v[1]:.4f} deg" for k, v in theirs.items())
        )


@dataclasses.dataclass(frozen=True)
class _RepeatedBoard(BoardModel):
    """A board whose points are listed ``copies`` times (a view's corners counted as often)."""

    copies: int = 1

    @property
    def points(self):
        return np.tile(super().points, (self.copies, 1))


def _weighted(views, pick):
    """The views drawn by ``pick`` (indices, some twice or more) as each view drawn once with
    its corners counted as often as it was drawn: a board whose points repeat as often as
    the most drawn view's, a view's copies beyond its count not seen (NaN)."""
    counts = np.bincount(pick, minlength=len(views.names))
    drawn = np.flatnonzero(counts)
    copies = int(counts.max())
    board = _RepeatedBoard(**dataclasses.asdict(views.board), copies=copies)
    n = views.corners.shape[1]
    corners = np.full((len(drawn), copies * n, 2), np.nan)
    for row, v in enumerate(drawn):
        corners[row, : counts[v] * n] = np.tile(views.corners[v], (counts[v], 1))
    picked = views.subset(drawn)
    return dataclasses.replace(picked, board=board, corners=corners)


def _refits(train, X0, picks, flange_errors: bool, weighted: bool = False) -> np.ndarray:
    """The camera-in-flange pose fitted to each pick of the views, as (rotation vector,
    translation) from ``X0``: shape (K, 6). ``weighted``: a view drawn k times is fitted once
    with its corners counted k times (:func:`_weighted`), not as k views."""
    from rworld_cli import spatial
    from rworld_cli.vision import calibrate as vc

    deltas = []
    for pick in picks:
        views = _weighted(train, pick) if weighted else train.subset(pick)
        try:
            r = vc.calibrate_views(views, flange_errors=flange_errors)
        except vc.CalibrationRefused:
            continue
        X = r.T_mount_camera
        deltas.append(
            np.r_[spatial.rotation_vector(X[:3, :3] @ X0[:3, :3].T), X[:3, 3] - X0[:3, 3]]
        )
    return np.array(deltas)


def bootstrap(
    train, ours, count: int, flange_errors: bool = False, left_out: int = 0, weighted=False
) -> None:
    """Section 2: the bootstrap (views drawn with replacement; ``weighted``: a view drawn k
    times fitted once, its corners counted k times) or, with ``left_out`` d, the delete-d
    jackknife (n - d views drawn without: no view twice; Shao and Wu 1989, the variance
    ``(n - d) / d`` times the picks' spread)."""
    rng = np.random.default_rng(0)
    n = len(train.names)
    if left_out:
        picks = [np.sort(rng.choice(n, n - left_out, replace=False)) for _ in range(count)]
    else:
        picks = [rng.integers(0, n, n) for _ in range(count)]
    t0 = time.perf_counter()
    deltas = _refits(train, ours.T_mount_camera, picks, flange_errors, weighted)
    if left_out:
        spread = np.sqrt((n - left_out) / left_out * np.mean((deltas - deltas.mean(0)) ** 2, 0))
        label, how = "jackknife", f"delete-{left_out} jackknife ({n - left_out} views a pick)"
    else:
        spread = np.std(deltas, axis=0, ddof=1)
        label, how = "bootstrap", "bootstrap"
        if weighted:
            label, how = "weighted", "bootstrap, a view drawn k times weighted k"
    reported = ours.sigma[9:15]
    pixels = np.sqrt(np.diag(ours.covariance_pixels))[9:15]
    model = "flange errors" if flange_errors else "exact robot"
    print(
        f"2. {how} over the {n} fitted views ({model}): {len(deltas)} picks "
        f"({time.perf_counter() - t0:.0f} s); camera in flange"
    )
    print(f"   {'':<10} {'rx':>7} {'ry':>7} {'rz':>7} {'x':>7} {'y':>7} {'z':>7}  (deg, mm)")
    scale = np.r_[np.degrees([1, 1, 1]), [1000] * 3]
    for row, v in ((label, spread), ("reported", reported), ("pixels", pixels)):
        print(f"   {row:<10} " + " ".join(f"{x:7.3f}" for x in v * scale))
    r = reported / spread
    print(
        f"   reported / {label}: {' '.join(f'{x:.2f}' for x in r)} "
        f"(range {r.min():.2f}-{r.max():.2f})"
    )


def spreads(train, ours, fe, count: int, model: str = "both") -> None:
    """Section 2 on kuka2's fitted views: the sigma of each model (``model``: ``both``,
    ``exact`` or ``flange-errors``) against the bootstrap (``count`` draws for the exact
    robot, a quarter for the flange-error model) and the delete-d jackknife."""
    exact, flange = model in ("both", "exact"), model in ("both", "flange-errors")
    # no view twice in the jackknife: a view drawn twice is, to the flange-error model, two
    # views at one pose whose errors agree exactly (its fitted correlation and sigmas move)
    left_out = round(0.37 * len(train.names))  # a bootstrap's draw leaves out 37 %
    for d in (0, left_out):
        if exact:
            bootstrap(train, ours, count, left_out=d)
        if flange:
            bootstrap(train, fe, count // 4, flange_errors=True, left_out=d)
        if flange and not d:  # to this model a view drawn twice is not two views: weighted
            bootstrap(train, fe, count // 4, flange_errors=True, weighted=True)


def simulated(seeds: int, flange_noise=(0.0, 0.0), noise_px: float = 0.3) -> None:
    from rworld_cli import spatial
    from rworld_cli.model.vision import BoardModel, CameraModel
    from rworld_cli.vision import calibrate as vc
    from rworld_cli.vision.emulate import random_views

    camera = CameraModel(
        "cam",
        1280,
        1024,
        1000.0,
        1002.0,
        641.0,
        511.0,
        np.array([-0.12, 0.08, 0.0005, -0.0003, -0.02]),
    )
    unknown = CameraModel("cam", 1280, 1024, 0.0, 0.0, 0.0, 0.0)
    board = BoardModel("board", "chessboard", 9, 6, 0.03)
    X = spatial.make_transform(spatial.rpy_to_matrix(np.radians([2, -3, 90])), [0.05, -0.08, 0.1])
    Z = spatial.make_transform(spatial.rpy_to_matrix(np.radians([180, 0, 30])), [0.8, 0.1, 0.02])
    errors, bound, reported = [], [], []
    t0 = time.perf_counter()
    for seed in range(seeds):
        v = random_views(
            np.random.default_rng(seed),
            camera,
            board,
            X,
            Z,
            20,
            noise_px=noise_px,
            flange_noise=flange_noise,
        )
        v = dataclasses.replace(v, camera=unknown)
        r = vc.calibrate_views(v, flange_errors=flange_noise != (0.0, 0.0))
        errors.append(
            np.r_[
                r.camera.intrinsics - camera.intrinsics,
                spatial.rotation_vector(r.T_mount_camera[:3, :3] @ X[:3, :3].T),
                r.T_mount_camera[:3, 3] - X[:3, 3],
                spatial.rotation_vector(r.T_holder_board[:3, :3] @ Z[:3, :3].T),
                r.T_holder_board[:3, 3] - Z[:3, 3],
            ]
        )
        # the bound: the inverse Fisher information of the model the data follow (pixel noise
        # only; or pixel noise and the flange's errors, the flange-error model's own)
        cov = r.covariance if r.flange_sigma is not None else r.covariance_pixels
        bound.append(np.sqrt(np.diag(cov)))
        reported.append(r.sigma)
    rms = lambda a: np.sqrt(np.mean(np.square(a), axis=0))  # noqa: E731
    spread, crb, rep = rms(errors), rms(bound), rms(reported)
    robot = (
        f", flange poses off by {np.degrees(flange_noise[0]):.3g} deg and "
        f"{flange_noise[1] * 1000:.3g} mm (the flange-error model)"
        if flange_noise != (0.0, 0.0)
        else " (the exact-robot model)"
    )
    print(
        f"3. simulated: {seeds} seeds x 20 views, {noise_px} px noise{robot} "
        f"({(time.perf_counter() - t0) / seeds:.2f} s a calibration)"
    )
    groups = {
        "intrinsics": slice(0, 9),
        "camera in flange": slice(9, 15),
        "board in base": slice(15, 21),
    }
    for name, g in groups.items():
        e, s = spread[g] / crb[g], rep[g] / spread[g]
        print(
            f"   {name:<17} error / bound {e.min():.2f}-{e.max():.2f} (mean {e.mean():.2f}); "
            f"reported sigma / spread {s.min():.2f}-{s.max():.2f} (mean {s.mean():.2f})"
        )
    e, s = spread / crb, rep / spread
    print(
        f"   all 21: error / bound mean {e.mean():.3f}, max {e.max():.2f}; reported / spread "
        f"mean {s.mean():.3f}"
    )


def timings(images_dir: str | None) -> None:
    import cv2

    from rworld_cli import spatial
    from rworld_cli.model.vision import BoardModel, CameraModel
    from rworld_cli.vision import calibrate as vc
    from rworld_cli.vision.detect import detect
    from rworld_cli.vision.emulate import random_views

    board = BoardModel("board", "chessboard", 24, 17, 0.015)
    files = (
        sorted(Path(images_dir).glob("*"))
        if images_dir
        else sorted((DATA / "images").glob("*.png"))
    )
    times, found = [], 0
    for f in files:
        grey = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
        if grey is None:
            continue
        t0 = time.perf_counter()
        d = detect(f.name, grey, board)
        times.append(time.perf_counter() - t0)
        found += d.refused is None
    print(
        f"4. corners found in {found} of {len(times)} images of 1920 x 1200: "
        f"{np.mean(times):.2f} s an image (median {np.median(times):.2f}), one core"
    )
    camera = CameraModel(
        "cam",
        1280,
        1024,
        1000.0,
        1002.0,
        641.0,
        511.0,
        np.array([-0.12, 0.08, 0.0005, -0.0003, -0.02]),
    )
    board = BoardModel("board", "chessboard", 9, 6, 0.03)
    X = spatial.make_transform(spatial.rpy_to_matrix(np.radians([2, -3, 90])), [0.05, -0.08, 0.1])
    Z = spatial.make_transform(spatial.rpy_to_matrix(np.radians([180, 0, 30])), [0.8, 0.1, 0.02])
    v = random_views(np.random.default_rng(7), camera, board, X, Z, 30, noise_px=0.3)
    v = dataclasses.replace(v, camera=CameraModel("cam", 1280, 1024, 0, 0, 0, 0))
    t = []
    for _ in range(3):
        t0 = time.perf_counter()
        vc.calibrate_views(v)
        t.append(time.perf_counter() - t0)
    print(
        f"   a 30-view calibration (54 corners a view, intrinsics free): {min(t):.2f} s (best of 3)"
    )
    kuka = _kuka2()
    t0 = time.perf_counter()
    vc.calibrate_views(kuka)
    print(f"   the 28 real views (408 corners a view): {time.perf_counter() - t0:.2f} s")


def rendering() -> None:
    """Images of the test cell's overhead camera (1280 x 1024): rworld's renderer against
    trimesh's ray casting of the same scene's pixel-centre rays (which only finds what each ray
    hits first, no print, no area sampling); and the detector on the image."""
    import trimesh

    from rworld_cli.api import load_world, sense
    from rworld_cli.geometry import shape_mesh
    from rworld_cli.sensing.sensors import sensable_bodies
    from rworld_cli.vision.detect import detect
    from rworld_cli.vision.render import _pixel_rays, render_view

    cell = REPO / "tests" / "data" / "vision" / "cell" / "cell.yaml"
    world, _ = load_world(str(cell))
    cam = world.cell.sensors["overhead"].camera
    boards = [(o.board, world.T_world(n)) for n, o in world.cell.objects.items() if o.board]
    bodies = sensable_bodies(world)
    occ = [shape_mesh(b.shape).triangles(b.T_world_owner) for b in bodies if b.owner != "board"]
    T = world.T_world("overhead")
    render_view(cam, T, boards, occ)  # the pixels' rays, once per camera
    times = []
    for seed in range(5):
        t0 = time.perf_counter()
        image, depth = render_view(cam, T, boards, occ, seed=seed)
        times.append(time.perf_counter() - t0)
    found = detect("overhead", image, boards[0][0])
    _, readings = sense(str(cell))
    exact = np.array(readings[0].image["boards"]["board"]["pixels"])
    err = np.linalg.norm(found.corners - exact, axis=1)
    # trimesh: every body's triangles as one mesh, the same pixel-centre rays
    tris = np.concatenate([shape_mesh(b.shape).triangles(b.T_world_owner) for b in bodies])
    mesh = trimesh.Trimesh(
        vertices=tris.reshape(-1, 3), faces=np.arange(len(tris) * 3).reshape(-1, 3)
    )
    n, _ = _pixel_rays(tuple(cam.intrinsics.tolist()), cam.width, cam.height)
    d = np.concatenate([n.reshape(-1, 2), np.ones((n.shape[0] * n.shape[1], 1))], axis=1)
    d = d @ T[:3, :3].T
    t0 = time.perf_counter()
    first = trimesh.ray.ray_triangle.RayMeshIntersector(mesh).intersects_first(
        np.broadcast_to(T[:3, 3], d.shape), d
    )
    t_trimesh = time.perf_counter() - t0
    print(
        f"5. rendering the test cell's overhead camera, 1280 x 1024 (boards area-sampled 8 x 8 at "
        f"edges, blur 0.6 px, noise 2 grey): {min(times):.2f} s an image (best of 5), "
        f"{1 / min(times):.1f} images a second; trimesh's ray casting of the same pixel-centre "
        f"rays (first hit only): {t_trimesh:.1f} s ({t_trimesh / min(times):.0f}x); rays that "
        f"hit something: trimesh {int(np.sum(first >= 0))}"
    )
    print(
        f"   OpenCV finds the rendered corners {err.max():.3f} px from the exact projection at "
        f"most, {np.sqrt(np.mean(err**2)):.3f} px rms"
    )


def _plan_rows(cell: Path, camera: str, rows) -> None:
    """Planned against random views' predicted error, one line for each (views, candidates)."""
    from rworld_cli.api import plan_views

    for count, candidates in rows:
        t0 = time.perf_counter()
        run = plan_views(str(cell / "cell.yaml"), camera, count, candidates=candidates)
        f = run.figures
        print(
            f"   {count:2d} views of {run.usable} usable / {candidates}: planned "
            f"{f['error'] * 1000:.4f} mm, random {f['random_error'] * 1000:.4f} mm "
            f"({f['random_error'] / f['error']:.2f}x), D-optimal alone "
            f"{np.hypot(f['d_optimal_position'], 0.3 * f['d_optimal_rotation']) * 1000:.4f} mm; "
            f"{time.perf_counter() - t0:.1f} s"
        )


def _plan_loop(cell: Path, camera: str, truth: np.ndarray) -> None:
    """The loop on 8 planned views (the default candidates): images rendered at each, corners
    found, the camera calibrated; its pose in its mount against ``truth`` (4, 4)."""
    import shutil
    import tempfile

    from rworld_cli import spatial
    from rworld_cli.api import calibrate_camera, plan_views, render_camera

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp) / "cell"
        shutil.copytree(cell, work)
        run = plan_views(str(work / "cell.yaml"), camera, 8, captures=str(work / "c.yaml"))
        t0 = time.perf_counter()
        for k, q in enumerate(run.joints):
            image = str(work / f"view{k + 1:02d}.png")
            render_camera(str(work / "cell.yaml"), camera, image, {"ur5": q.tolist()}, seed=k)
        t_render = (time.perf_counter() - t0) / len(run.joints)
        calibration = calibrate_camera(str(work / "c.yaml"))
        result = calibration.result
        X = result.T_mount_camera
        turn = np.linalg.norm(spatial.rotation_vector(truth[:3, :3].T @ X[:3, :3]))
        used = sum(d.refused is None for d in calibration.detections)
        cam = result.camera
        print(
            f"   the loop, 8 planned views ({used} with the board found) rendered at "
            f"{cam.width} x {cam.height} ({t_render:.2f} s an image), calibrated: the camera "
            f"{np.abs(X[:3, 3] - truth[:3, 3]).max() * 1000:.4f} mm and "
            f"{np.degrees(turn):.5f} deg from the cell's, fx {cam.fx:.3f} px, rms "
            f"{result.rms:.4f} px"
        )


def planning() -> None:
    """plan-views on the test cell (a UR5 with a camera on its flange over a 9 x 6 board):
    the planned views' predicted camera-in-flange error against random usable views, and the
    whole loop for 8 planned views: images rendered there, corners found, the camera
    calibrated, its pose against the cell's; the same eye-to-hand."""
    from rworld_cli import spatial

    data = REPO / "tests" / "data" / "vision"
    print("6. plan-views on the test cell (predicted error at a point 300 mm ahead, 0.1 px):")
    rows = ((8, 300), (12, 300), (16, 300), (12, 600), (8, 1000), (12, 1000))
    _plan_rows(data / "cell", "wrist_camera", rows)
    # the cell's wrist camera: 60 mm along the tool's y and 30 mm along its z, not turned
    _plan_loop(data / "cell", "wrist_camera", spatial.make_transform(None, [0.0, 0.06, 0.03]))
    # eye-to-hand: the overhead camera (at 450, 0, 900 mm, turned 180 deg about x) and a 7 x 5
    # board on the flange (tests/data/vision/cell_eye_to_hand)
    print("   eye-to-hand (the board on the flange, the overhead camera):")
    _plan_rows(data / "cell_eye_to_hand", "overhead", ((8, 300), (12, 300)))
    truth = spatial.make_transform(spatial.rot_x(np.pi), [0.45, 0.0, 0.9])
    _plan_loop(data / "cell_eye_to_hand", "overhead", truth)


def planning_vendors() -> None:
    """Section 6b (module docstring)."""
    import tempfile

    from rworld_cli.api import plan_views
    from rworld_cli.errors import UserError
    from tests.vision.camera_cells import camera_cell

    print("6b. plan-views on vendor robots (8 views of 1000 candidates, without and with the")
    print("    candidates drawn around the first choice):")
    for name in ("kr6r900sixx", "cr7ial", "iiwa14", "vs060", "gen3", "ur10e", "gp12"):
        for fixed in (False, True):
            setup = "eye-to-hand" if fixed else "eye-in-hand"
            with tempfile.TemporaryDirectory() as tmp:
                cell = camera_cell(name, Path(tmp) / "cell", fixed=fixed)
                row = []
                for refine in (0, None):
                    t0 = time.perf_counter()
                    try:
                        run = plan_views(str(cell), "wrist_camera", 8, refine=refine)
                    except UserError as exc:
                        row.append(f"refused: {exc.message[:90]}")
                        break
                    f = run.figures
                    row.append(
                        f"{f['error'] * 1000:.4f} mm / random {f['random_error'] * 1000:.4f} mm "
                        f"= {f['random_error'] / f['error']:.2f}x ({run.usable} usable"
                        + (f", {f['refined']} of {f['refine']} around" if f["refine"] else "")
                        + f", {time.perf_counter() - t0:.1f} s)"
                    )
                print(f"   {name} {setup}: " + "; ".join(row), flush=True)


def _board_camera(model, name: str, joints: np.ndarray, result=None) -> np.ndarray:
    """The wrist camera in the board's frame at each of ``joints`` (K, n) of ``model``'s
    device ``name``, shape (K, 4, 4) [m]: the cell's own, or through ``result``'s camera in
    its mount and board in its holder (what a program on that robot meets)."""
    from rworld_cli.world.tree import World

    world = World(model)
    mount = world.parent("wrist_camera")
    out = []
    for q in joints:
        world.set_joints(name, q)
        if result is None:
            out.append(world.T("board", "wrist_camera"))
        else:
            T = world.T(name, mount) @ result.T_mount_camera
            out.append(np.linalg.solve(result.T_holder_board, T))
    return np.array(out)


def _robot_truth(root: Path, cell: Path, seed: int, rng) -> tuple:
    """One truth of section 7: ``cell`` (its robot the first device, a wrist camera over a
    board) copied to a truth off its model (``rng``), 40 planned views (``seed``) emulated
    through it with 0.1 px of noise, the exact-robot fit against the two steps; (exact,
    through, the robot's fit, the camera to the board at the held-out joints before and after
    against the truth's, max [m], the three calibrations' time [s])."""
    from rworld_cli.api import calibrate_camera, calibrate_robot, plan_views
    from rworld_cli.schema.loader import load_cell
    from tests.vision.camera_cells import (
        emulated_captures,
        list_pose_file,
        robot_off_its_model,
    )

    truth = load_cell(str(robot_off_its_model(cell, root / "truth", rng))).cell
    nominal = load_cell(str(cell)).cell
    name = next(iter(nominal.devices))
    plan = plan_views(str(cell), "wrist_camera", 40, candidates=300, seed=seed)
    captures = emulated_captures(root, nominal, truth, plan.joints, rng, 0.1)
    nominal_captures = nominal_copy(cell, root)  # before the two steps list their file
    t0 = time.perf_counter()
    exact = calibrate_camera(str(captures), holdout_every=4)
    obs = root / "obs.yaml"
    calibrate_camera(str(captures), write_robot_observations=str(obs))
    fit = calibrate_robot(str(cell), [str(obs)], output=str(cell / "robot_cal.yaml"))
    list_pose_file(cell, "robot_cal.yaml")
    through = calibrate_camera(str(captures), holdout_every=4, through_robot=True)
    seconds = time.perf_counter() - t0
    t0 = time.perf_counter()
    one = calibrate_camera(str(nominal_captures), holdout_every=4, with_robot=True)
    seconds_one = time.perf_counter() - t0
    held = plan.joints[3::4]
    true = _board_camera(truth, name, held)
    before = _board_camera(nominal, name, held, exact.result)
    after = _board_camera(load_cell(str(cell)).cell, name, held, through.result)
    robot = one.result.robot
    joined = np.linalg.solve(
        one.result.T_holder_board,
        robot.model.poses(robot.p, held) @ one.result.T_mount_camera,
    )
    off = [float(np.abs(x[:, :3, 3] - true[:, :3, 3]).max()) for x in (before, after, joined)]
    return exact, through, fit.as_dict(), off[0], off[1], seconds, one, off[2], seconds_one


def nominal_copy(cell: Path, root: Path) -> Path:
    """A copy of ``cell`` (``root/nominal``) and a capture file naming it beside
    ``root/captures.yaml``; returns the capture file."""
    import shutil

    shutil.copytree(cell, root / "nominal")
    text = (root / "captures.yaml").read_text()
    out = root / "captures_nominal.yaml"
    out.write_text(text.replace("robot: {cell: cell,", "robot: {cell: nominal,"))
    return out


def robot(truths: int) -> None:
    """Section 7 (module docstring)."""
    import shutil
    import tempfile

    print(f"7. the robot's own errors from the camera ({truths} truths, 40 views, 0.1 px):")
    rows = []
    for seed in range(truths):
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp)
            cell = root / "cell"
            shutil.copytree(REPO / "tests" / "data" / "vision" / "cell", cell)
            exact, through, f, before, after, seconds, one, joined, seconds_one = _robot_truth(
                root, cell, seed, np.random.default_rng(100 + seed)
            )
            rows.append(
                (
                    exact.held_out_rms,
                    through.held_out_rms,
                    before * 1000,
                    after * 1000,
                    f["sigma_mm"],
                    f["fit_mm"]["after"]["rms"],
                    f["identified"],
                    seconds,
                    one.held_out_rms,
                    joined * 1000,
                    one.result.robot.rank,
                    seconds_one,
                )
            )
            print(
                f"   truth {seed}: held-out {rows[-1][0]:.3f} px -> two steps {rows[-1][1]:.3f} "
                f"px, one estimate {rows[-1][8]:.3f} px; camera to board {rows[-1][2]:.3f} mm -> "
                f"{rows[-1][3]:.4f} mm, {rows[-1][9]:.4f} mm; two steps: observations' sigma "
                f"{rows[-1][4]:.3f} mm, robot fit rms {rows[-1][5]:.3f} mm, {rows[-1][6]} "
                f"parameters identified, {seconds:.1f} s; one: {rows[-1][10]} identified, "
                f"{seconds_one:.1f} s"
            )
    r = np.array(rows)
    print(
        f"   median over {truths}: held-out {np.median(r[:, 0]):.3f} -> two steps "
        f"{np.median(r[:, 1]):.3f} px (max {r[:, 1].max():.3f}), one estimate "
        f"{np.median(r[:, 8]):.3f} px (max {r[:, 8].max():.3f}); camera to board "
        f"{np.median(r[:, 2]):.3f} -> {np.median(r[:, 3]):.4f} mm (max {r[:, 3].max():.4f}), "
        f"{np.median(r[:, 9]):.4f} mm (max {r[:, 9].max():.4f})"
    )


def robot_spread(seeds: int) -> None:
    """Section 7c (module docstring)."""
    import shutil
    import tempfile

    from rworld_cli.api import calibrate_camera, plan_views
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.vision.calibrate import _perturbed
    from rworld_cli.world.tree import World
    from tests.vision.camera_cells import emulated_captures, robot_off_its_model

    print(f"7c. one estimate with the robot: its sigma against {seeds} noise seeds (0.1 px):")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        cell = root / "cell"
        shutil.copytree(REPO / "tests" / "data" / "vision" / "cell", cell)
        truth = load_cell(str(robot_off_its_model(cell, root / "truth", np.random.default_rng(7))))
        nominal = load_cell(str(cell)).cell
        name = next(iter(nominal.devices))
        plan = plan_views(str(cell), "wrist_camera", 40, candidates=300, seed=0)
        checks = plan.joints[::8]  # five of the views: the camera's place at them
        true_world = World(truth.cell)
        true = []
        for q in checks:
            true_world.set_joints(name, q)
            true.append(true_world.T("board", "wrist_camera")[:3, 3])
        true = np.array(true).ravel()
        estimates, predicted, factors = [], [], []
        for k in range(seeds):
            captures = emulated_captures(
                root, nominal, truth.cell, plan.joints, np.random.default_rng(1000 + k), 0.1
            )
            r = calibrate_camera(str(captures), with_robot=True).result
            robot = r.robot
            P = len(robot.p)

            def place(d, r=r, robot=robot, P=P):
                X = _perturbed(r.T_mount_camera, d[9:15])
                Z = _perturbed(r.T_holder_board, d[15:21])
                F = robot.model.poses(robot.p + d[21:], checks)
                return np.linalg.solve(Z, F @ X)[:, :3, 3].ravel()

            x0 = np.zeros(21 + P)
            J = np.empty((len(true), 21 + P))
            for j in range(21 + P):
                e = np.zeros_like(x0)
                e[j] = 1e-7
                J[:, j] = (place(x0 + e) - place(x0 - e)) / 2e-7
            cov = np.block([[r.covariance, r.robot_cross], [r.robot_cross.T, robot.covariance]])
            estimates.append(place(x0))
            predicted.append(np.sqrt(np.diag(J @ cov @ J.T)))
            factors.append(robot.variance_factor)
        est = np.array(estimates)
        spread = est.std(axis=0, ddof=1)
        sigma = np.mean(predicted, axis=0)
        error = np.sqrt(np.mean((est - true) ** 2, axis=0))
        ratio = sigma / spread
        print(
            f"   the camera's place relative to the board at 5 views (15 coordinates): predicted "
            f"sigma / observed spread median {np.median(ratio):.3f} ({ratio.min():.3f}-"
            f"{ratio.max():.3f}); rms error against the truth / predicted sigma median "
            f"{np.median(error / sigma):.3f} (max {np.max(error / sigma):.3f}); sigma "
            f"{np.median(sigma) * 1000:.4f} mm median; a-posteriori factor "
            f"{np.mean(factors):.3f}"
        )


def robot_setups() -> None:
    """Section 7d (module docstring)."""
    import tempfile

    from rworld_cli.api import calibrate_camera, plan_views
    from rworld_cli.schema.loader import load_cell
    from tests.vision.camera_cells import camera_cell, emulated_captures, robot_off_its_model

    print("7d. one estimate with the robot, both set-ups, robots new to the vision tests:")
    for name in ("vs060", "gen3"):
        for fixed in (False, True):
            with tempfile.TemporaryDirectory() as tmp:
                root = Path(tmp)
                cell = camera_cell(name, root / "cell", fixed=fixed)
                off = robot_off_its_model(cell, root / "truth", np.random.default_rng(11))
                truth, nominal = load_cell(str(off)).cell, load_cell(str(cell)).cell
                plan = plan_views(str(cell), "wrist_camera", 40, candidates=300, seed=0)
                captures = emulated_captures(
                    root, nominal, truth, plan.joints, np.random.default_rng(5), 0.1
                )
                exact = calibrate_camera(str(captures), holdout_every=4)
                t0 = time.perf_counter()
                one = calibrate_camera(str(captures), holdout_every=4, with_robot=True)
                seconds = time.perf_counter() - t0
                robot = one.result.robot
                print(
                    f"   {name} {'eye-to-hand' if fixed else 'eye-in-hand'}: held-out "
                    f"{exact.held_out_rms:.3f} px (exact robot) -> {one.held_out_rms:.3f} px; "
                    f"{robot.rank} of {6 * robot.device.dof} joint parameters identified, "
                    f"a-posteriori factor {robot.variance_factor:.3f}; {seconds:.1f} s"
                )


def robot_vendors(truths: int) -> None:
    """Section 7 on vendor robots (module docstring)."""
    import tempfile

    from tests.vision.camera_cells import camera_cell

    print(f"7b. the robot's own errors from the camera, vendor robots ({truths} truths each):")
    for name in ("kr6r900sixx", "cr7ial", "iiwa14"):
        rows = []
        for seed in range(truths):
            with tempfile.TemporaryDirectory() as tmp:
                root = Path(tmp)
                cell = camera_cell(name, root / "cell")
                exact, through, f, _, _, _, one, *_ = _robot_truth(
                    root, cell, seed, np.random.default_rng(200 + seed)
                )
                rows.append((exact.held_out_rms, through.held_out_rms, one.held_out_rms))
                print(
                    f"   {name} truth {seed}: held-out {rows[-1][0]:.3f} -> two steps "
                    f"{rows[-1][1]:.3f} px, one estimate {rows[-1][2]:.3f} px; sigma "
                    f"{f['sigma_mm']:.3f} mm, robot fit {f['fit_mm']['after']['rms']:.3f} mm, "
                    f"{f['identified']} of {f['parameters']} identified (two steps), "
                    f"{one.result.robot.rank} of {6 * one.result.robot.device.dof} (one)"
                )
        r = np.array(rows)
        print(
            f"   {name}: held-out median {np.median(r[:, 0]):.3f} -> two steps "
            f"{np.median(r[:, 1]):.3f} px (at most {r[:, 1].max():.3f}), one estimate "
            f"{np.median(r[:, 2]):.3f} px (at most {r[:, 2].max():.3f})"
        )


def flange_errors_vendor(robot: str, truths: int) -> None:
    """Section 7e: the flange-error model on a vendor robot off its model (``robot`` of
    ``tests/data/probe_robots``): 40 planned views emulated through the truth with 0.1 px of
    noise, the nominal flanges reported; each model's held-out rms, and the camera's place
    relative to the board at the held-out joints through the nominal robot and the written
    poses (what a program on the controller meets) against the truth's."""
    import tempfile

    from rworld_cli.api import calibrate_camera, plan_views
    from rworld_cli.schema.loader import load_cell
    from tests.vision.camera_cells import camera_cell, emulated_captures, robot_off_its_model

    print(f"7e. the flange-error model on {robot} off its model ({truths} truths):")
    for seed in range(truths):
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp)
            cell = camera_cell(robot, root / "cell")
            rng = np.random.default_rng(300 + seed)
            truth = load_cell(str(robot_off_its_model(cell, root / "truth", rng))).cell
            nominal = load_cell(str(cell)).cell
            name = next(iter(nominal.devices))
            plan = plan_views(str(cell), "wrist_camera", 40, candidates=300, seed=seed)
            captures = emulated_captures(root, nominal, truth, plan.joints, rng, 0.1)
            held = plan.joints[3::4]
            true = _board_camera(truth, name, held)[:, :3, 3]
            row = []
            for flange_errors in (False, True):
                t0 = time.perf_counter()
                run = calibrate_camera(str(captures), holdout_every=4, flange_errors=flange_errors)
                place = _board_camera(nominal, name, held, run.result)[:, :3, 3]
                off = np.linalg.norm(place - true, axis=1) * 1000
                row.append(
                    f"{'flange errors' if flange_errors else 'exact robot'} {run.held_out_rms:.3f}"
                    f" px, place rms {np.sqrt(np.mean(off**2)):.3f} mm (max {off.max():.3f}; "
                    f"{time.perf_counter() - t0:.1f} s)"
                )
            print(f"   truth {seed}: held-out " + "; ".join(row), flush=True)


def plan_with_robot(truths: int) -> None:
    """Section 7f (module docstring)."""
    import shutil
    import tempfile

    from rworld_cli.api import plan_views
    from tests.vision.camera_cells import camera_cell

    def cell_of(robot: str, root: Path) -> Path:
        cell = root / "cell"
        if robot == "ur5":
            shutil.copytree(REPO / "tests" / "data" / "vision" / "cell", cell)
        else:
            camera_cell(robot, cell)
        return cell

    print("7f. plan-views --with-robot: the camera-to-board pose's predicted error at the")
    print("    robot's poses (0.1 px, 300 mm lever), 300 candidates:")
    for robot in ("ur5", "gp12"):
        with tempfile.TemporaryDirectory() as tmp:
            cell = cell_of(robot, Path(tmp))
            for count in (8, 12, 20, 40):
                t0 = time.perf_counter()
                f = plan_views(
                    str(cell), "wrist_camera", count, candidates=300, with_robot=True
                ).figures
                print(
                    f"   {robot} {count:2d} views: planned {f['error'] * 1000:.4f} mm, the views "
                    f"chosen for the camera alone {f['camera_choice_error'] * 1000:.4f} mm "
                    f"({f['camera_choice_error'] / f['error']:.2f}x), random "
                    f"{f['random_error'] * 1000:.4f} mm ({f['random_error'] / f['error']:.2f}x);"
                    f" {len(f['robot_parameters'])} robot parameters; "
                    f"{time.perf_counter() - t0:.1f} s",
                    flush=True,
                )
    print("    the prediction against truths (each robot off its model, 12 views planned with")
    print("    the robot, calibrate-camera --with-robot, the error at the plan's poses):")
    for robot, count in (("ur5", truths), ("gp12", max(truths // 2, 1))):
        _prediction_against_truths(robot, cell_of, count)


def _prediction_against_truths(robot: str, cell_of, truths: int) -> None:
    """Section 7f's second part on ``robot`` (``cell_of(robot, root)`` its cell)."""
    import tempfile

    from rworld_cli import spatial
    from rworld_cli.api import calibrate_camera, plan_views
    from rworld_cli.schema.loader import load_cell
    from tests.vision.camera_cells import emulated_captures, robot_off_its_model

    with tempfile.TemporaryDirectory() as tmp:
        cell = cell_of(robot, Path(tmp))
        plan = plan_views(str(cell), "wrist_camera", 12, candidates=300, with_robot=True)
        nominal = load_cell(str(cell)).cell
        name = next(iter(nominal.devices))
        checks = plan.check_joints
        squared = []
        for seed in range(truths):
            root = Path(tmp) / f"truth{seed}"
            root.mkdir()
            rng = np.random.default_rng(500 + seed)
            truth = load_cell(str(robot_off_its_model(cell, root / "truth", rng))).cell
            true = _board_camera(truth, name, checks)
            captures = emulated_captures(root, nominal, truth, plan.joints, rng, 0.1)
            captures.write_text(captures.read_text().replace("{cell: cell,", "{cell: ../cell,"))
            r = calibrate_camera(str(captures), with_robot=True).result
            F = r.robot.model.poses(r.robot.p, checks)
            est = np.linalg.solve(r.T_holder_board, F @ r.T_mount_camera)
            d = est[:, :3, 3] - true[:, :3, 3]
            turn = spatial.rotation_vector(np.swapaxes(true[:, :3, :3], 1, 2) @ est[:, :3, :3])
            squared.append(float(np.mean(np.sum(d**2, axis=1) + 0.09 * np.sum(turn**2, axis=1))))
        observed = float(np.sqrt(np.mean(squared)))
        print(
            f"   {robot}: predicted {plan.figures['error'] * 1000:.4f} mm, observed (rms over "
            f"{truths} truths and the {len(checks)} poses) {observed * 1000:.4f} mm: "
            f"{observed / plan.figures['error']:.3f}x"
        )


def aprilgrid() -> None:
    """Section 8 (module docstring)."""
    import shutil
    import tempfile

    import cv2

    from rworld_cli.api import plan_views, render_camera
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.vision.detect import refine_tag_corners
    from rworld_cli.vision.emulate import seen_corners
    from rworld_cli.world.tree import World

    chessboard = (
        "    geometry: {box: [0.3, 0.21, 0.004], origin: {xyz: [0.12, 0.075, 0.002]}}\n"
        "    board: {pattern: chessboard, columns: 9, rows: 6, square: 0.03}"
    )
    grid = (
        "    geometry: {box: [0.324, 0.22, 0.004], origin: {xyz: [0.15, 0.098, 0.002]}}\n"
        "    board: {pattern: aprilgrid, columns: 6, rows: 4, square: 0.04, spacing: 0.012}"
    )
    methods = ("NONE", "SUBPIX", "CONTOUR", "APRILTAG")
    print("8. AprilTag grid corners against the exact projection (px):")
    with tempfile.TemporaryDirectory() as tmp:
        cell = Path(tmp) / "cell"
        shutil.copytree(REPO / "tests" / "data" / "vision" / "cell", cell)
        text = (cell / "cell.yaml").read_text()
        (cell / "cell.yaml").write_text(text.replace(chessboard, grid))
        model = load_cell(str(cell)).cell
        board = model.objects["board"].board
        dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
        plan = plan_views(str(cell), "wrist_camera", 8, candidates=150)
        shots = [("overhead", None)] + [("wrist_camera", q) for q in plan.joints]
        for blur in (0.6, 1.2):
            errors: dict[str, list] = {m: [] for m in (*methods, "rworld edges")}
            pulls: dict[str, list] = {m: [] for m in errors}
            for k, (camera, q) in enumerate(shots):
                image = Path(tmp) / f"{camera}{k}.png"
                joints = None if q is None else {"ur5": q.tolist()}
                render_camera(str(cell), camera, str(image), joints, blur_px=blur, seed=k)
                world = World(model)
                if q is not None:
                    world.set_joints("ur5", q)
                cam = model.sensors[camera].camera
                exact = seen_corners(cam, board, world.T(camera, "board")).reshape(-1, 4, 2)
                grey = cv2.imread(str(image), cv2.IMREAD_GRAYSCALE)
                for m in methods:
                    p = cv2.aruco.DetectorParameters()
                    p.cornerRefinementMethod = getattr(cv2.aruco, f"CORNER_REFINE_{m}")
                    corners, ids, _ = cv2.aruco.ArucoDetector(dictionary, p).detectMarkers(grey)
                    for c, tag in zip(corners, [] if ids is None else np.ravel(ids)):
                        if tag >= len(exact) or not np.isfinite(exact[tag]).all():
                            continue
                        quads = {m: np.asarray(c, dtype=float).reshape(4, 2)}
                        if m == "SUBPIX":
                            quads["rworld edges"] = refine_tag_corners(grey, quads[m])
                        for name, quad in quads.items():
                            d = quad - exact[tag]
                            out = exact[tag] - exact[tag].mean(axis=0)
                            out /= np.linalg.norm(out, axis=1, keepdims=True)
                            errors[name] += np.linalg.norm(d, axis=1).tolist()
                            pulls[name] += (-(d * out).sum(axis=1)).tolist()
            print(f"   blur {blur} px ({len(shots)} images):")
            for name, e in errors.items():
                e = np.array(e)
                print(
                    f"   {name:<14} {len(e):4d} corners: rms {np.sqrt(np.mean(e**2)):.3f}, "
                    f"max {e.max():.3f}, inward {np.mean(pulls[name]):+.3f}"
                )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=80)
    parser.add_argument("--bootstrap", type=int, default=200)
    parser.add_argument("--images", default=None, help="detect every image in this folder")
    parser.add_argument(
        "--only",
        choices=[
            "real",
            "rendering",
            "planning",
            "robot",
            "robot-spread",
            "robot-setups",
            "aprilgrid",
            "spread",
            "flange-errors",
            "plan-with-robot",
        ],
        default=None,
        help="run one section",
    )
    parser.add_argument("--truths", type=int, default=10, help="--only robot: how many truths")
    parser.add_argument(
        "--set",
        default="kuka2",
        choices=["kuka1", "kuka2", "kuka3", "tabb1"],
        help="--only spread: the real set (its views but every 4th)",
    )
    parser.add_argument(
        "--model",
        default="both",
        choices=["both", "exact", "flange-errors"],
        help="--only spread: the model of the robot's poses whose sigma is checked",
    )
    parser.add_argument(
        "--vendors",
        action="store_true",
        help="--only robot: on vendor robots (3 truths each); --only planning: on vendor robots",
    )
    args = parser.parse_args()
    import cv2

    print(f"CPU: {cpu_model()}; OpenCV {cv2.__version__}, numpy {np.__version__}")
    if args.only == "robot":
        if args.vendors:
            robot_vendors(min(args.truths, 3))
        else:
            robot(args.truths)
        return
    if args.only == "planning" and args.vendors:
        planning_vendors()
        return
    if args.only == "robot-spread":
        robot_spread(args.seeds)
        return
    if args.only == "robot-setups":
        robot_setups()
        return
    if args.only == "real":
        for name in ("kuka1", "kuka3", "kuka2", "tabb1"):
            real_data(DATA.parent / name)
        synthetic_truth()
        return
    if args.only == "plan-with-robot":
        plan_with_robot(args.truths)
        return
    if args.only == "flange-errors":
        flange_errors_vendor("gp12", min(args.truths, 3))
        return
    if args.only == "spread":
        from rworld_cli.vision import calibrate as vc

        views = _views(DATA.parent / args.set)
        index = np.arange(len(views.names))
        train = views.subset(np.setdiff1d(index, index[3::4]))
        ours = vc.calibrate_views(train)
        fe = vc.calibrate_views(train, flange_errors=True)
        spreads(train, ours, fe, args.bootstrap, args.model)
        return
    if args.only is not None:
        {"rendering": rendering, "planning": planning, "aprilgrid": aprilgrid}[args.only]()
        return
    for name in ("kuka1", "kuka3", "tabb1"):
        real_data(DATA.parent / name)
    _views_, train, ours, fe = real_data(DATA)
    synthetic_truth()
    spreads(train, ours, fe, args.bootstrap)
    simulated(args.seeds)
    simulated(max(args.seeds // 4, 4), flange_noise=(np.radians(0.02), 0.2e-3), noise_px=0.1)
    timings(args.images)
    rendering()
    planning()


if __name__ == "__main__":
    main()
