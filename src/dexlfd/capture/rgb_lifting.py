"""RGB-only lifting: MediaPipe's metric world landmarks placed in the camera frame.

Without a depth image the hand's absolute depth is unknown; these models place
MediaPipe's hand-centred metric world landmarks: at an assumed wrist depth
(:func:`lift_assumed_depth`), by the translation that best reprojects them
(:func:`lift_world_fit`), or by the rigid pose that best reprojects them
(:func:`fit_hand_pose`, over a stream :class:`PnPTracker`). All are APPROXIMATIONS
(intrinsics and MediaPipe's hand-size prior); see :mod:`dexlfd.capture.lifting`.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import check_positive
from dexlfd.capture.camera_models import Intrinsics, deproject_pinhole
from dexlfd.errors import InvalidInput
from dexlfd.rotations import rotation_angle

__all__ = [
    "PnPConfig",
    "PnPTracker",
    "fit_hand_pose",
    "lift_assumed_depth",
    "lift_world_fit",
    "shape_change",
]


@dataclass(frozen=True, slots=True)
class PnPConfig:
    """Plausibility gates of the ``"pnp"`` lift (:class:`PnPTracker`).

    MediaPipe's world landmarks are roughly camera-aligned: on the shared real video
    the fitted rotation is 12 deg (median) from identity, 16 deg at the 95th
    percentile, while the mirror-ambiguous flips of a near-planar hand are > 140 deg.

    The shape gate (:class:`PnPTracker`) holds the depth while the hand changes
    shape: the :func:`shape_change` over the last ``shape_lag`` frames (slow
    curls add up) above ``shape_factor`` times its ``shape_quantile`` percentile
    over the last ``shape_window`` frames (the tracker's own noise level, not
    raised by the changes themselves) and above ``shape_min``, or such a frame
    within the last ``shape_hold`` frames. On the shared real video the
    frame-to-frame shape change is 0.005-0.02 while the hand keeps its shape and
    0.04-0.4 while it closes or opens; a hand moving rigidly changes shape only
    by its landmark noise. There, a still hand opening, making fists and
    pinching kept its wrist depth within 1.8 cm (frames 240-330; 22 cm without
    the gate), with 52 % of the frames held.
    """

    max_rotation_deg: float = 75.0  # largest accepted world-landmark -> camera rotation [deg]
    max_depth_step: float = 0.2  # largest relative depth change between accepted frames [-]
    max_rms_rel: float = 0.15  # largest reprojection RMS over the hand's pixel diagonal [-]
    reset_after: int = 5  # consecutive gated frames after which the gate trusts the fit again
    shape_factor: float = 3.0  # shape change over its running median that holds the depth [-]
    shape_min: float = 0.005  # shape change never taken as the hand changing shape [-]
    shape_window: int = 90  # frames of the shape changes the noise level is taken from [frames]
    shape_hold: int = 4  # frames the depth stays held after a shape change [frames]
    shape_lag: int = 3  # the shape change is measured over this many frames [frames]
    shape_quantile: float = 25.0  # percentile of the past shape changes taken as noise [%]

    def __post_init__(self) -> None:
        if not 0 < self.max_rotation_deg <= 180:
            raise InvalidInput(f"max_rotation_deg must be in (0, 180], got {self.max_rotation_deg}")
        check_positive(self.max_depth_step, "max_depth_step")
        check_positive(self.max_rms_rel, "max_rms_rel")
        if int(self.reset_after) < 1:
            raise InvalidInput(f"reset_after must be >= 1, got {self.reset_after}")
        check_positive(self.shape_factor, "shape_factor")
        if self.shape_min < 0:
            raise InvalidInput(f"shape_min must be >= 0, got {self.shape_min}")
        if not 0 <= self.shape_quantile <= 100:
            raise InvalidInput(f"shape_quantile must be in [0, 100], got {self.shape_quantile}")
        for name in ("shape_window", "shape_hold", "shape_lag"):
            if int(getattr(self, name)) < 1:
                raise InvalidInput(f"{name} must be >= 1, got {getattr(self, name)}")


def lift_assumed_depth(
    uv_px: FloatArray, world_m: FloatArray, K: Intrinsics, wrist_depth_m: float
) -> FloatArray:
    """World landmarks placed with the wrist at ``wrist_depth_m`` on its pixel's ray.

    MediaPipe's world landmarks are metric and camera-aligned but centred on the
    hand; the wrist's pixel and an assumed depth fix the translation. APPROXIMATE.
    """
    uv = np.asarray(uv_px, dtype=np.float64)
    W = np.asarray(world_m, dtype=np.float64)
    wrist = deproject_pinhole(uv[0], np.asarray(wrist_depth_m, dtype=np.float64), K)
    return wrist + (W - W[0])


def lift_world_fit(uv_px: FloatArray, world_m: FloatArray, K: Intrinsics) -> FloatArray:
    """Translate the world landmarks so they reproject onto the detected pixels.

    Solves ``f_x (X_k + T_x) = (u_k - c_x)(Z_k + T_z)`` and the same in y for
    ``T`` by linear least squares (algebraic error), i.e. depth from the hand's
    apparent size. APPROXIMATE (intrinsics and MediaPipe's hand-size prior).
    """
    uv = np.asarray(uv_px, dtype=np.float64)
    W = np.asarray(world_m, dtype=np.float64)
    du = uv[:, 0] - 0.5 - K.cx
    dv = uv[:, 1] - 0.5 - K.cy
    n = uv.shape[0]
    A = np.zeros((2 * n, 3))
    A[:n, 0] = K.fx
    A[:n, 2] = -du
    A[n:, 1] = K.fy
    A[n:, 2] = -dv
    b = np.concatenate([du * W[:, 2] - K.fx * W[:, 0], dv * W[:, 2] - K.fy * W[:, 1]])
    T, *_ = np.linalg.lstsq(A, b, rcond=None)
    return W + T


def fit_hand_pose(
    uv_px: FloatArray,
    world_m: FloatArray,
    K: Intrinsics,
    guess: tuple[FloatArray, FloatArray] | None = None,
    max_rotation_deg: float = 75.0,
    *,
    first_plausible: bool = False,
) -> tuple[FloatArray, FloatArray, float] | None:
    """Rigid pose ``(R, t)`` of the world landmarks that best reprojects them (PnP).

    Minimises the reprojection error of ``x_cam = R X_world + t`` over the
    landmark pairs. Candidates: OpenCV's SQPnP (global), a Levenberg-Marquardt
    refinement of ``guess`` (the previous frame's pose: keeps the same branch
    of the near-planar hand's two-fold ambiguity), or without a guess one of
    ``(I, t_lin)`` (:func:`lift_world_fit`'s translation). Those with the hand in front of the
    camera and ``R`` within ``max_rotation_deg`` of identity (world landmarks are
    roughly camera-aligned) compete on RMS reprojection error.

    Parameters
    ----------
    uv_px : ndarray, shape (k, 2)
        Image landmarks [px], corner convention; ``k >= 4``.
    world_m : ndarray, shape (k, 3)
        MediaPipe world landmarks [m] (hand-centred, metric).
    K : Intrinsics
    guess : (R, t), optional
        Initial pose (rotation matrix, translation [m]), e.g. the previous frame's.
    max_rotation_deg : float
        Plausibility bound on the rotation [deg].
    first_plausible : bool
        Return SQPnP's pose when it is plausible, without refining the other
        candidate (about 7x cheaper; the best pose only when SQPnP's is).

    Returns
    -------
    (R, t, rms_px) or None
        Rotation ``(3, 3)``, translation ``(3,)`` [m], RMS reprojection error [px];
        None when no finite plausible pose exists.
    """
    import cv2

    uv = np.asarray(uv_px, dtype=np.float64)
    W = np.asarray(world_m, dtype=np.float64)
    ok = np.isfinite(uv).all(axis=1) & np.isfinite(W).all(axis=1)
    if ok.sum() < 4:
        return None
    obj = np.ascontiguousarray(W[ok])
    img = np.ascontiguousarray(uv[ok] - 0.5)  # OpenCV: pixel centres at integers
    Km = K.matrix
    seeds: list[tuple[FloatArray, FloatArray]] = []
    try:
        found, r, t = cv2.solvePnP(obj, img, Km, np.zeros(5), flags=cv2.SOLVEPNP_SQPNP)
        if found:
            seeds.append((_vec(r), _vec(t)))
    except cv2.error:
        pass
    if first_plausible and seeds:
        first = _plausible(obj, img, K, *seeds[0], max_rotation_deg)
        if first is not None:
            return first
    if guess is not None:
        rg = _vec(cv2.Rodrigues(np.asarray(guess[0], dtype=np.float64))[0])
        seeds.append(_refine(obj, img, Km, rg, _vec(guess[1])))
    else:
        t_lin = lift_world_fit(uv[ok], W[ok], K)[0] - W[ok][0]
        if np.isfinite(t_lin).all() and t_lin[2] > 0:
            seeds.append(_refine(obj, img, Km, np.zeros(3), t_lin))
    best: tuple[FloatArray, FloatArray, float] | None = None
    for r, t in seeds:
        fit = _plausible(obj, img, K, r, t, max_rotation_deg)
        if fit is not None and (best is None or fit[2] < best[2]):
            best = fit
    return best


def _plausible(
    obj: FloatArray, img: FloatArray, K: Intrinsics, r: FloatArray, t: FloatArray, max_deg: float
) -> tuple[FloatArray, FloatArray, float] | None:
    """``(R, t, rms_px)`` of the pose ``(r, t)`` (Rodrigues vector, [m]), None if implausible.

    Implausible: not finite, a landmark behind the camera, or ``R`` more than
    ``max_deg`` from identity.
    """
    import cv2

    if not (np.isfinite(r).all() and np.isfinite(t).all()):
        return None
    R = np.asarray(cv2.Rodrigues(r)[0], dtype=np.float64)
    P = obj @ R.T + t
    if (P[:, 2] <= 0).any() or math.degrees(rotation_angle(R, np.eye(3))) > max_deg:
        return None
    proj = np.column_stack([K.fx * P[:, 0] / P[:, 2] + K.cx, K.fy * P[:, 1] / P[:, 2] + K.cy])
    rms = float(np.sqrt(np.mean(np.sum((proj - img) ** 2, axis=1))))
    return R, t.copy(), rms


def shape_change(a: FloatArray, b: FloatArray) -> float:
    """Scale-free shape difference of two landmark sets (Procrustes distance) [-].

    Both sets are centred and scaled to unit RMS radius; the value is the RMS
    distance left after the best rotation of ``a`` onto ``b`` (Kabsch). 0 for the
    same hand moved, rotated or scaled; ~0.1-0.4 between an open hand and a fist.
    NaN when either set has a non-finite or coincident landmark set.
    """
    A = np.asarray(a, dtype=np.float64)
    B = np.asarray(b, dtype=np.float64)
    if not (np.isfinite(A).all() and np.isfinite(B).all()):
        return math.nan
    A = A - A.mean(axis=0)
    B = B - B.mean(axis=0)
    ra, rb = np.sqrt(np.mean(np.sum(A**2, axis=1))), np.sqrt(np.mean(np.sum(B**2, axis=1)))
    if ra <= 0 or rb <= 0:
        return math.nan
    A, B = A / ra, B / rb
    U, _, Vt = np.linalg.svd(B.T @ A)
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(U @ Vt)))])
    R = U @ D @ Vt  # rotation taking A onto B
    return float(np.sqrt(np.mean(np.sum((A @ R.T - B) ** 2, axis=1))))


def _refine(
    obj: FloatArray, img: FloatArray, Km: FloatArray, r: FloatArray, t: FloatArray
) -> tuple[FloatArray, FloatArray]:
    import cv2

    r1, t1 = r.reshape(3, 1).copy(), t.reshape(3, 1).copy()
    try:
        r2, t2 = cv2.solvePnPRefineLM(obj, img, Km, np.zeros(5), r1, t1)
    except cv2.error:
        return np.full(3, np.nan), np.full(3, np.nan)
    return _vec(r2), _vec(t2)


def _vec(a: object) -> FloatArray:
    return np.asarray(a, dtype=np.float64).ravel()


class PnPTracker:
    """The ``"pnp"`` lift over a stream: per-frame PnP, seeded and gated by the past.

    Each frame's pose comes from :func:`fit_hand_pose` with the last accepted pose
    as a seed. A fit is *gated* when its reprojection RMS exceeds
    ``max_rms_rel`` of the hand's pixel diagonal, or its depth differs from the
    last accepted one by more than ``max_depth_step`` (relative): the hand then
    keeps its fitted rotation and its ray but the last accepted depth. After
    ``reset_after`` consecutive gated frames the fit is trusted again (the hand
    really moved). Without any plausible fit the frame is NaN (the motion stage
    treats it as a gap). ``counts`` tallies ``fitted``, ``gated`` and ``failed``.

    The fitted depth follows the hand's apparent size, which MediaPipe's
    landmarks change when the fingers curl (on the shared real video a still hand
    making a fist read 14 cm deeper). So while the hand changes shape (the shape
    gate of :class:`PnPConfig`) the depth is *held*: the fit's depth ratio to the
    previous frame goes into a running correction ``log z_out = log z_fit + c``
    instead of into the output, and the hand keeps its fitted ray and rotation.
    Depth changes during a shape change are therefore not seen (a hand that moves
    in depth while grasping loses that part), and ``c`` is never relaxed: depth is
    relative to the first frame. :meth:`reset` keeps ``c``. ``shape_held`` counts
    the held frames.

    ``seeded=False``: each frame's first plausible pose (``fit_hand_pose``'s
    ``first_plausible``: SQPnP's, else the refinement of the last frame's), no gate,
    no hold; for a recording whose poses are then all replaced by the whole
    recording's (:mod:`dexlfd.capture.recording_pose`), which keeps only which frames
    have a pose at all.
    """

    def __init__(self, cfg: PnPConfig | None = None, *, seeded: bool = True) -> None:
        self.cfg = cfg or PnPConfig()
        self.seeded = seeded
        self._pose: tuple[FloatArray, FloatArray] | None = None
        self._gated_run = 0
        self.counts = {"fitted": 0, "gated": 0, "failed": 0}
        self.shape_held = 0
        self.last_rms_px = math.nan
        self._shape_past()

    def _shape_past(self) -> None:
        self._worlds: deque[FloatArray] = deque(maxlen=self.cfg.shape_lag)  # past landmarks
        self._z_fit = math.nan  # last frame's fitted (uncorrected) depth [m]
        self._log_c = 0.0  # depth correction, log z_out - log z_fit
        self._changes: deque[float] = deque(maxlen=self.cfg.shape_window)
        self._since_change = self.cfg.shape_hold  # frames since the last shape change

    def reset(self) -> None:
        """Forget the seed and the jump gate (e.g. after the hand was lost).

        The depth correction, the last fitted depth and the shape past are kept: a
        hand lost for a few frames while it is a fist comes back with the same
        correction instead of the fist's full depth error.
        """
        self._pose = None
        self._gated_run = 0

    def _hold_depth(self, W: FloatArray) -> bool:
        """Whether the hand is changing shape (the depth is held this frame)."""
        cfg = self.cfg
        past = self._worlds[0] if self._worlds else None
        self._worlds.append(W)
        change = math.nan if past is None else shape_change(past, W)
        if not math.isfinite(change):
            return False
        floor = math.inf  # the noise level, unknown for the first frames
        if len(self._changes) >= 5:
            floor = float(np.percentile(self._changes, cfg.shape_quantile))
        self._changes.append(change)
        if change > max(cfg.shape_factor * floor, cfg.shape_min):
            self._since_change = 0
        else:
            self._since_change += 1
        return self._since_change < cfg.shape_hold and math.isfinite(self._z_fit)

    def lift(self, uv_px: FloatArray, world_m: FloatArray, K: Intrinsics) -> FloatArray:
        """Camera-frame landmarks ``(21, 3)`` [m] of one frame (NaN when no fit)."""
        W = np.asarray(world_m, dtype=np.float64)
        uv = np.asarray(uv_px, dtype=np.float64)
        fit = fit_hand_pose(
            uv, W, K, self._pose, self.cfg.max_rotation_deg, first_plausible=not self.seeded
        )
        if fit is None:
            self.counts["failed"] += 1
            self.last_rms_px = math.nan
            return np.full(W.shape, np.nan)
        R, t, rms = fit
        self.last_rms_px = rms
        if not self.seeded:  # no gate, no hold: the pose is only the next seed
            self.counts["fitted"] += 1
            self._pose = (R, t)
            return W @ R.T + t
        wrist = R @ W[0] + t  # the wrist's fitted camera position [m]
        if self._hold_depth(W):
            self._log_c -= math.log(float(wrist[2]) / self._z_fit)  # keep last frame's depth
            self.shape_held += 1
        self._z_fit = float(wrist[2])
        t = t + (math.exp(self._log_c) - 1.0) * wrist  # the wrist along its ray
        finite = np.isfinite(uv).all(axis=1)
        span = uv[finite].max(axis=0) - uv[finite].min(axis=0)
        diag = float(np.hypot(*span))
        gated = False
        if self._pose is not None and self._gated_run < self.cfg.reset_after:
            z_prev = float(self._pose[1][2])
            if (
                abs(t[2] - z_prev) > self.cfg.max_depth_step * z_prev
                or rms > self.cfg.max_rms_rel * diag
            ):
                t = t * (z_prev / t[2])  # same ray, the last accepted depth
                gated = True
        if gated:
            self._gated_run += 1
            self.counts["gated"] += 1
        else:
            self._gated_run = 0
            self.counts["fitted"] += 1
        self._pose = (R, t)
        return W @ R.T + t
