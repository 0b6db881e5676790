"""Synthetic MediaPipe-like hand keypoints from an end-effector pose series.

This is the inverse of the motion definition (thesis Section 4.2): given the
end-effector position, quaternion and gripper opening, it places 21 hand
landmarks in the base frame such that :func:`dexlfd.motion.pose_from_keypoints`
gives back the same position (wrist, Eq. 4.10), the same quaternion (through
the Euler angles of Eq. 4.11) and the same gripper opening (Eq. 4.14).

Construction for each frame:

1. ``H_h = q * M^-1`` (M the mount rotation) and its Euler angles
   ``(psi, theta, phi)`` of ``H_x(phi) H_y(theta) H_z(psi)``.
2. A template right hand (fingers along +x, palm down, thumb on +y; a left hand
   is its mirror image) is rotated by ``H_h`` and put at the wrist.
3. The thumb tip is moved so that the pitch of Eq. (4.11) is ``theta`` (its
   reach along the hand's heading and its height below the wrist), and the
   index tip is put at ``t - v`` with ``v`` of length ``d`` along
   ``cos(phi) (-sin psi, cos psi, 0) + sin(phi) z`` (which gives back yaw and
   roll and ``|t - i| = d``). The other thumb and index joints follow their
   tips proportionally, so the skeleton stays hand-like.

In the default ``mode="heading"`` every orientation is reachable (the Euler
triple with ``cos(phi) >= 0`` is used; at ``cos(phi) = 0`` yaw is undefined).
The literal printed Eq. (4.11) (``mode="thesis"``) can only express rotations
whose yaw and roll have cosines of the same sign (both use ``y_t - y_i``);
others raise an error naming the frame.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import as_float_array
from dexlfd.errors import InvalidInput
from dexlfd.io import Demonstration
from dexlfd.motion import MotionConfig, demonstration_from_keypoints, euler_from_quat
from dexlfd.motion.definition import INDEX_TIP, THUMB_TIP, WRIST, hand_quat_from_euler
from dexlfd.rotations import matrix_from_quat

__all__ = ["HandModelConfig", "demonstration_with_hand", "hand_keypoints_from_pose"]

# Template right hand in its rest frame [m]: wrist at 0, fingers +x, palm down (-z), thumb +y.
# MediaPipe order: 0 wrist; thumb 1-4; index 5-8; middle 9-12; ring 13-16; pinky 17-20.
_TEMPLATE = np.array(
    [
        [0.000, 0.000, 0.000],
        [0.025, 0.022, -0.008],
        [0.045, 0.042, -0.014],
        [0.068, 0.052, -0.018],
        [0.090, 0.056, -0.022],
        [0.090, 0.025, 0.000],
        [0.128, 0.028, -0.002],
        [0.152, 0.029, -0.006],
        [0.172, 0.030, -0.012],
        [0.095, 0.005, 0.000],
        [0.138, 0.005, -0.002],
        [0.165, 0.005, -0.006],
        [0.188, 0.005, -0.012],
        [0.090, -0.015, 0.000],
        [0.128, -0.017, -0.002],
        [0.152, -0.019, -0.006],
        [0.172, -0.020, -0.012],
        [0.080, -0.033, 0.000],
        [0.108, -0.038, -0.002],
        [0.126, -0.041, -0.006],
        [0.142, -0.044, -0.010],
    ]
)
_THUMB = (1, 2, 3)
_INDEX = (5, 6, 7)


@dataclass(frozen=True, slots=True)
class HandModelConfig:
    """Shape and noise of the synthetic hand."""

    scale_range: tuple[float, float] = (0.9, 1.1)  # hand size relative to the template
    joint_noise: float = 0.002  # std of noise on joints that do not define the pose [m]
    keypoint_noise: float = 0.0  # std of noise on every landmark incl. 0, 4, 8 [m]

    def __post_init__(self) -> None:
        lo, hi = self.scale_range
        if not 0 < lo <= hi:
            raise InvalidInput(f"scale_range must satisfy 0 < lo <= hi, got {self.scale_range}")
        if self.joint_noise < 0 or self.keypoint_noise < 0:
            raise InvalidInput("joint_noise and keypoint_noise must be >= 0")


def hand_keypoints_from_pose(
    position: FloatArray,
    quaternion: FloatArray,
    gripper: FloatArray,
    rng: np.random.Generator,
    cfg: HandModelConfig | None = None,
    *,
    hand: str = "right",
    mount: str = "thesis",
    mode: str = "heading",
) -> FloatArray:
    """Hand landmarks whose motion definition gives back the pose.

    Parameters
    ----------
    position : ndarray, shape (n, 3)
        End-effector (wrist) position [m], base frame.
    quaternion : ndarray, shape (n, 4)
        End-effector orientation, unit, scalar-last.
    gripper : ndarray, shape (n,)
        Gripper opening = thumb-index distance [m], > 0.
    rng : numpy.random.Generator
        Hand size and joint noise.
    cfg : HandModelConfig, optional
    hand : {"right", "left"}
    mount : str
        Key of :data:`dexlfd.motion.MOUNTS` used by the motion definition.
    mode : {"heading", "thesis", "triad"}
        Euler convention of :func:`dexlfd.motion.euler_from_keypoints` to invert.

    Returns
    -------
    ndarray, shape (n, 21, 3)
        Landmarks [m]; NaN rows where an input row is NaN.

    Raises
    ------
    InvalidInput
        Bad shapes, a non-positive opening, or an orientation Eq. (4.11) cannot express.
    """
    cfg = cfg or HandModelConfig()
    p = as_float_array(position, "position", shape=(None, 3))
    n = p.shape[0]
    q = as_float_array(quaternion, "quaternion", shape=(n, 4))
    g = as_float_array(gripper, "gripper", shape=(n,))
    if hand not in ("right", "left"):
        raise InvalidInput(f"hand must be 'right' or 'left', got {hand!r}")
    if mode not in ("heading", "thesis", "triad"):
        raise InvalidInput(f"mode must be 'heading', 'thesis' or 'triad', got {mode!r}")
    ok = np.isfinite(p).all(1) & np.isfinite(q).all(1) & np.isfinite(g)
    if (g[ok] <= 0).any():
        i = int(np.flatnonzero(ok & (g <= 0))[0])
        raise InvalidInput(f"gripper must be > 0 (yaw/roll undefined at 0), got {g[i]} at {i}")
    euler = _euler_to_invert(q, ok, mount, mode)
    s = 1.0 if hand == "right" else -1.0
    template = _TEMPLATE * rng.uniform(*cfg.scale_range) * np.array([1.0, s, 1.0])
    R = matrix_from_quat(hand_quat_from_euler(euler))
    kp = np.einsum("nij,kj->nki", R, template)  # hand points relative to the wrist
    noise = rng.normal(0.0, cfg.joint_noise, kp.shape)
    noise[:, [WRIST, THUMB_TIP, INDEX_TIP]] = 0.0
    kp = kp + noise
    thumb_tip, index_dir = _tip_directions(kp, template, R, euler, s, mode)
    v_norm = np.linalg.norm(index_dir, axis=1, keepdims=True)
    index_tip = thumb_tip - g[:, None] * index_dir / np.where(v_norm > 0, v_norm, 1.0)
    kp = _move_tips(kp, thumb_tip, index_tip) + p[:, None, :]
    if cfg.keypoint_noise > 0:
        kp = kp + rng.normal(0.0, cfg.keypoint_noise, kp.shape)
    kp[~ok] = np.nan
    return kp


def _euler_to_invert(q: FloatArray, ok: BoolArray, mount: str, mode: str) -> FloatArray:
    """Euler angles ``(psi, theta, phi)`` (n, 3) [rad] of each pose that ``mode`` can express.

    ``heading``/``triad`` take the triple with ``cos(phi) >= 0``; ``thesis`` raises
    :class:`InvalidInput` for a rotation whose yaw and roll cosines differ in sign.
    """
    euler = euler_from_quat(np.where(ok[:, None], q, [0.0, 0.0, 0.0, 1.0]), mount)
    if mode in ("heading", "triad"):
        # the other Euler triple of the same rotation has cos(phi) >= 0, as heading roll needs
        flip = np.cos(euler[:, 2]) < 0
        alt = np.column_stack([euler[:, 0] + np.pi, np.pi - euler[:, 1], euler[:, 2] + np.pi])
        return np.where(flip[:, None], np.angle(np.exp(1j * alt)), euler)
    psi, phi = euler[:, 0], euler[:, 2]
    bad = ok & (np.cos(psi) * np.cos(phi) < -1e-12)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InvalidInput(
            f"quaternion[{i}] is not expressible by the printed Eq. (4.11) with mount "
            f"{mount!r}: yaw {np.degrees(psi[i]):.1f} deg and roll {np.degrees(phi[i]):.1f} deg "
            "need cosines of the same sign; use mode='heading' or another mount"
        )
    return euler


def _tip_directions(
    kp: FloatArray,
    template: FloatArray,
    R: FloatArray,
    euler: FloatArray,
    s: float,
    mode: str,
) -> tuple[FloatArray, FloatArray]:
    """The thumb tip relative to the wrist ``u`` (n, 3) [m] and the direction of ``t - i``.

    Placed so that ``mode``'s Euler angles of Eq. (4.11) give back ``euler``; ``s`` is
    the hand sign (+1 right, -1 left).
    """
    psi, theta, phi = euler[:, 0], euler[:, 1], euler[:, 2]
    c_psi, c_phi = np.cos(psi), np.cos(phi)
    rho = np.hypot(template[THUMB_TIP, 0], template[THUMB_TIP, 2])
    if mode == "triad":
        # u = R (rho, a, 0) and t - i = d R y (x s): Gram-Schmidt of (u, v) gives back R
        u_new = np.einsum("nij,j->ni", R, [rho, template[THUMB_TIP, 1], 0.0])
        return u_new, s * R[:, :, 1]
    if mode == "thesis":
        # thumb tip: printed pitch from the wrist-thumb vector u = t - w (x-z plane)
        u = kp[:, THUMB_TIP]
        u_new = np.stack([rho * np.cos(theta), u[:, 1], -rho * np.sin(theta)], axis=1)
        # index tip: yaw and roll from v = t - i, |v| = d_ti (Eq. 4.14)
        sign = np.where(c_psi < 0, -1.0, 1.0) * s
        v_dir = np.stack([-np.sin(psi) * c_phi, c_psi * c_phi, -c_psi * np.sin(phi)], axis=1)
        return u_new, v_dir * sign[:, None]
    # heading frame: forward f, lateral l; u = rho cos(theta) f + a l - rho sin(theta) z
    n = euler.shape[0]
    f = np.stack([c_psi, np.sin(psi), np.zeros(n)], axis=1)
    lat = np.stack([-np.sin(psi), c_psi, np.zeros(n)], axis=1)
    u_new = rho * np.cos(theta)[:, None] * f + template[THUMB_TIP, 1] * lat
    u_new[:, 2] = -rho * np.sin(theta)
    # v = cos(phi) (-sin psi, cos psi, 0) + sin(phi) z, times the hand sign
    v_dir = c_phi[:, None] * lat
    v_dir[:, 2] = np.sin(phi)
    return u_new, v_dir * s


def _move_tips(kp: FloatArray, thumb_tip: FloatArray, index_tip: FloatArray) -> FloatArray:
    """Put the thumb and index tips at their targets; their joints follow proportionally."""
    d_thumb = thumb_tip - kp[:, THUMB_TIP]
    d_index = index_tip - kp[:, INDEX_TIP]
    for k, (jt, ji) in enumerate(zip(_THUMB, _INDEX, strict=True), start=1):
        kp[:, jt] += d_thumb * (k / 4)
        kp[:, ji] += d_index * (k / 4)
    kp[:, THUMB_TIP] = thumb_tip
    kp[:, INDEX_TIP] = index_tip
    return kp


def demonstration_with_hand(
    demo: Demonstration,
    rng: np.random.Generator,
    cfg: HandModelConfig | None = None,
    motion_cfg: MotionConfig | None = None,
) -> Demonstration:
    """Fill ``demo.keypoints`` with a synthetic hand and recompute the motion from it.

    Parameters
    ----------
    demo : Demonstration
        Pose-level demonstration (e.g. from :func:`pick_place_demonstrations`).
    rng : numpy.random.Generator
    cfg : HandModelConfig, optional
    motion_cfg : MotionConfig, optional
        Motion definition used to recompute the pose; default ``mount="top_grasp"``
        (the synthetic tasks grasp from above), ``grasp_threshold`` midway
        between the demo's smallest and largest opening, no gap filling.

    Returns
    -------
    Demonstration
        Same ``t``; ``keypoints`` synthetic; position/quaternion/gripper recomputed
        by :func:`dexlfd.motion.demonstration_from_keypoints` (equal to the input
        up to round-off when ``cfg.keypoint_noise`` is 0).
    """
    if motion_cfg is None:
        g = demo.gripper[demo.valid]
        mid = float(0.5 * (g.min() + g.max())) if g.size else 0.1
        spread = float(g.max() - g.min()) if g.size else 0.0
        motion_cfg = MotionConfig(
            mount="top_grasp",
            grasp_threshold=max(mid, 1e-3),
            grasp_hysteresis=0.1 * spread,
            grasp_method="absolute",
            max_gap_s=0.0,
        )
    kp = hand_keypoints_from_pose(
        demo.position,
        demo.quaternion,
        demo.gripper,
        rng,
        cfg,
        hand=motion_cfg.hand,
        mount=motion_cfg.mount,
        mode=motion_cfg.euler_mode,
    )
    meta = dict(demo.meta)
    meta["hand"] = {
        "generator": "dexlfd.datasets.demonstration_with_hand",
        "note": "SYNTHETIC hand keypoints made from the end-effector pose",
        **asdict(cfg or HandModelConfig()),
    }
    return demonstration_from_keypoints(
        demo.t, kp, demo.valid, motion_cfg, meta=meta, extras=dict(demo.extras),
        frame=demo.frame,
    )  # fmt: skip
