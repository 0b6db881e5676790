"""Motion definition: hand keypoints -> end-effector pose and gripper opening.

Implements Section 4.2 of the thesis on MediaPipe's 21 landmarks in the robot
base frame: the wrist is the position (4.10); yaw, pitch and roll come from the
wrist, thumb tip and index tip (4.11); the quaternion is the composition
``H_x(phi) H_y(theta) H_z(psi)`` (4.12-4.13) followed by the fixed 90 degree
rotation about y that maps the hand's rest pose to the gripper's (4.2.2); the
gripper opening is the thumb-index distance (4.14).

Interpretations:

* Eq. (4.11) is printed with ``arctan`` of ratios, which loses the quadrant;
  we use ``atan2(numerator, denominator)`` with the same numerators and
  denominators, so the rest pose (all angles zero) is a right hand, palm down,
  fingers along +x, thumb tip on the +y side of the index tip. Angles are
  unwrapped over time.
* With the full quadrant, the printed pitch and roll (measured along base x and
  y) break for a hand yawed past 90 deg. By default they are measured along the
  hand's heading instead (``mode="heading"``, identical at zero yaw); the
  literal form is ``mode="thesis"``. In heading mode the roll's sign follows a
  right-handed roll of the hand (the printed ``z_i - z_t`` gives the mirror
  image); see :func:`euler_from_keypoints`.
* Euler angles from three points are singular near pitch +-90 deg (a hand
  pointing up or down): yaw and roll then swing by up to 180 deg between frames.
  ``mode="triad"`` takes the orientation from the wrist-thumb-index triad
  directly (:func:`hand_matrix_from_keypoints`), equal to Eq. (4.11) at the rest
  pose and for single-axis rotations, continuous everywhere else.
* On real hands the thumb and index tips move with the fingers (a pinch turns
  the wrist-thumb-index triangle although the hand does not turn), and a
  thumb-index vector near vertical makes Eq. (4.11)'s yaw and roll swing by up to
  180 deg between frames. ``mode="palm"`` (used by ``dexlfd record``) takes the
  orientation from the rigid part of the hand instead: wrist, index MCP and pinky
  MCP (:func:`palm_matrix_from_keypoints`), identical to the others at the rest
  pose; Euler angles are then only derived from its quaternion, for display.
* A left hand at rest has its thumb on the -y side; with ``hand="left"`` the
  thumb-index vector is reversed in the yaw and roll terms (an offset of pi),
  so a left hand's rest pose is also all zeros and rotations keep their sign.
* "The demonstration quaternion multiplying the quaternion rotated 90 degrees
  around the y-axis" is read as the right product ``H_h * H_y(pi/2)`` (a
  rotation about the hand's own y axis).

All functions are pure and broadcast over leading axes (time first).

References
----------
.. [1] Thesis, Section 4.2, Eqs. (4.10)-(4.14).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.rotations import quat_from_matrix, quat_multiply, quat_sign_continuous

__all__ = [
    "GRIPPER_FROM_HAND",
    "EULER_MODES",
    "HANDS",
    "INDEX_TIP",
    "MOUNTS",
    "PoseSeries",
    "THUMB_TIP",
    "WRIST",
    "euler_from_keypoints",
    "euler_from_quat",
    "gripper_opening",
    "hand_matrix_from_keypoints",
    "hand_quat_from_euler",
    "mount_quat",
    "palm_matrix_from_keypoints",
    "pose_from_keypoints",
    "quat_from_euler",
    "unwrap_valid",
]

WRIST = 0  # MediaPipe landmark indices
THUMB_TIP = 4
INDEX_MCP = 5
INDEX_TIP = 8
PINKY_MCP = 17

# fixed 90 deg rotation about y (Section 4.2.2), scalar-last
GRIPPER_FROM_HAND = np.array([0.0, np.sin(np.pi / 4), 0.0, np.cos(np.pi / 4)])

# Fixed rotation from the hand's rest frame to the end-effector frame, right-multiplied.
# "thesis": H_y(90 deg) of Section 4.2.2 (qb-SoftHand: a flat hand, fingers along +x, gives
# the tool z axis along +x). "top_grasp": 180 deg about x, for a parallel gripper: a flat
# palm-down hand gives the tool z axis pointing down, the usual top grasp of a Panda.
MOUNTS: dict[str, FloatArray] = {
    "identity": np.array([0.0, 0.0, 0.0, 1.0]),  # the hand's own frame (display)
    "thesis": GRIPPER_FROM_HAND,
    "top_grasp": np.array([1.0, 0.0, 0.0, 0.0]),
}


def mount_quat(mount: str) -> FloatArray:
    """The fixed hand-to-gripper rotation registered under ``mount`` (see ``MOUNTS``)."""
    if mount not in MOUNTS:
        raise InvalidInput(f"mount must be one of {sorted(MOUNTS)}, got {mount!r}")
    return MOUNTS[mount].copy()


HANDS = ("right", "left")
EULER_MODES = ("heading", "thesis", "triad", "palm")


@dataclass(frozen=True, slots=True)
class PoseSeries:
    """Per-frame end-effector pose derived from keypoints (NaN where unseen)."""

    position: FloatArray  # (..., 3) [m]
    euler: FloatArray  # (..., 3) yaw psi, pitch theta, roll phi [rad]
    quaternion: FloatArray  # (..., 4) scalar-last
    gripper: FloatArray  # (...,) [m]


def _check_hand(hand: str) -> float:
    if hand not in HANDS:
        raise InvalidInput(f"hand must be one of {HANDS}, got {hand!r}")
    return 1.0 if hand == "right" else -1.0


def euler_from_keypoints(
    keypoints: FloatArray, hand: str = "right", mode: str = "heading"
) -> FloatArray:
    """Yaw, pitch and roll of the hand from wrist, thumb tip and index tip (Eq. 4.11).

    With ``v = t - i`` (thumb tip minus index tip) and ``u = t - w`` (thumb tip
    minus wrist), yaw is ``psi = atan2(x_i - x_t, y_t - y_i)`` as printed. Pitch
    and roll:

    ``mode="thesis"``: the printed ratios under atan2,
    ``theta = atan2(z_w - z_t, x_t - x_w)``, ``phi = atan2(z_i - z_t, y_t - y_i)``.
    These measure the thumb's reach along the base x axis and the thumb-index
    spread along base y, which are the hand's forward and lateral directions only
    at zero yaw: a hand yawed past 90 deg reads as pitched by 180 deg.

    ``mode="heading"`` (default): the same ratios measured in the hand's heading
    frame, forward ``f = (cos psi, sin psi, 0)`` and lateral
    ``l = (-sin psi, cos psi, 0)``: ``theta = atan2(z_w - z_t, u . f)``,
    ``phi = atan2(z_t - z_i, v . l)``. A rotation about the vertical then
    changes only the yaw, and every orientation is reachable (``phi`` in
    [-pi/2, pi/2]). The roll's sign is flipped with respect to the print: with
    the printed ``z_i - z_t`` a hand rolling by +phi about its forward axis
    (``H_x(phi)``, right-handed, thumb side rising) gives -phi, so the gripper
    would roll the other way (the thesis's Eq. (4.9) frame is left-handed).
    Yaw and pitch already agree with ``H_z`` and ``H_y``. At zero yaw and
    roll the two modes agree.

    Parameters
    ----------
    keypoints : ndarray, shape (..., 21, 3)
        Landmarks in the base frame [m].
    hand : {"right", "left"}
        Which hand; a left hand's thumb-index vector is reversed (module docstring).
    mode : {"heading", "thesis", "triad", "palm"}
        "triad": the Euler angles of :func:`hand_matrix_from_keypoints`;
        "palm": those of :func:`palm_matrix_from_keypoints`.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(psi, theta, phi)`` = yaw about z, pitch about y, roll about x [rad],
        each in (-pi, pi]; NaN where a keypoint is NaN.
    """
    s = _check_hand(hand)
    if mode not in EULER_MODES:
        raise InvalidInput(f"mode must be one of {EULER_MODES}, got {mode!r}")
    kp = np.asarray(keypoints, dtype=np.float64)
    if mode in ("triad", "palm"):
        return euler_from_quat(quat_from_matrix(_rigid_matrix(kp, hand, mode)), "identity")
    w, th, ix = kp[..., WRIST, :], kp[..., THUMB_TIP, :], kp[..., INDEX_TIP, :]
    v = s * (th - ix)
    u = th - w
    psi = np.arctan2(-v[..., 0], v[..., 1])  # (4.11): atan2(x_i - x_t, y_t - y_i)
    if mode == "thesis":
        theta = np.arctan2(-u[..., 2], u[..., 0])  # (4.11)
        phi = np.arctan2(-v[..., 2], v[..., 1])  # (4.11)
    else:
        c, sn = np.cos(psi), np.sin(psi)
        theta = np.arctan2(-u[..., 2], u[..., 0] * c + u[..., 1] * sn)  # (4.11), heading frame
        # (4.11) in the heading frame; sign: z_t - z_i, so a right-handed roll of the hand
        # about its forward axis gives +phi (the printed z_i - z_t gives -phi)
        phi = np.arctan2(v[..., 2], -v[..., 0] * sn + v[..., 1] * c)
    return np.stack([psi, theta, phi], axis=-1)


def hand_matrix_from_keypoints(keypoints: FloatArray, hand: str = "right") -> FloatArray:
    """Rotation of the wrist-thumb-index triad (``mode="triad"``), shape ``(..., 3, 3)``.

    Lateral axis ``y_h = v / |v|`` with ``v = t - i`` (reversed for a left hand),
    forward axis ``x_h`` = the wrist-to-thumb vector ``u = t - w`` made orthogonal
    to ``y_h``, ``z_h = x_h x y_h``. At the rest pose of Eq. (4.11) this is the
    identity, for a rigidly rotated hand it is the rotation itself, and unlike
    the Euler angles of Eq. (4.11) it has no singularity at pitch +-90 deg (only
    when thumb, index and wrist are collinear). NaN where a keypoint is NaN.
    """
    s = _check_hand(hand)
    kp = np.asarray(keypoints, dtype=np.float64)
    v = s * (kp[..., THUMB_TIP, :] - kp[..., INDEX_TIP, :])
    u = kp[..., THUMB_TIP, :] - kp[..., WRIST, :]
    y, x = _gram_schmidt(v, u)
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def palm_matrix_from_keypoints(keypoints: FloatArray, hand: str = "right") -> FloatArray:
    """Rotation of the palm (wrist, index MCP, pinky MCP), shape ``(..., 3, 3)``.

    Forward axis ``x_h``: wrist to the midpoint of the index and pinky MCPs.
    Lateral axis ``y_h``: pinky MCP to index MCP (the thumb side of a right hand;
    reversed for a left hand) made orthogonal to ``x_h``. ``z_h = x_h x y_h`` (the
    back of the hand). A right hand palm down with its fingers along +x gives the
    identity, as the rest pose of Eq. (4.11) does. These three landmarks sit on
    the palm's rigid bones, so finger motion (a pinch, a fist) does not turn it.
    NaN where a landmark is NaN or the three are collinear.
    """
    s = _check_hand(hand)
    kp = np.asarray(keypoints, dtype=np.float64)
    w, i, p = kp[..., WRIST, :], kp[..., INDEX_MCP, :], kp[..., PINKY_MCP, :]
    x, y = _gram_schmidt(0.5 * (i + p) - w, s * (i - p))
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def _gram_schmidt(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Unit ``a`` and unit ``b`` made orthogonal to it (``(..., 3)`` each; NaN if degenerate)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        a_hat = a / np.linalg.norm(a, axis=-1, keepdims=True)
        b_perp = b - np.sum(b * a_hat, axis=-1, keepdims=True) * a_hat
        return a_hat, b_perp / np.linalg.norm(b_perp, axis=-1, keepdims=True)


def _axis_quat(angle: FloatArray, axis: int) -> FloatArray:
    q = np.zeros((*np.shape(angle), 4))
    q[..., axis] = np.sin(angle / 2)
    q[..., 3] = np.cos(angle / 2)
    return q


def hand_quat_from_euler(euler: FloatArray) -> FloatArray:
    """Hand orientation ``H_h = H_x(phi) H_y(theta) H_z(psi)`` (Eq. 4.13 composition).

    Parameters
    ----------
    euler : ndarray, shape (..., 3)
        ``(psi, theta, phi)`` [rad] as returned by :func:`euler_from_keypoints`.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions, scalar-last.
    """
    e = np.asarray(euler, dtype=np.float64)
    psi, theta, phi = e[..., 0], e[..., 1], e[..., 2]
    return quat_multiply(
        quat_multiply(_axis_quat(phi, 0), _axis_quat(theta, 1)), _axis_quat(psi, 2)
    )  # (4.13): Hamilton products of the three elementary rotations


def quat_from_euler(euler: FloatArray, mount: str = "thesis") -> FloatArray:
    """End-effector quaternion ``H_h * M``, scalar-last; ``M = H_y(pi/2)`` for the thesis."""
    return quat_multiply(hand_quat_from_euler(euler), mount_quat(mount))  # Sec. 4.2.2


def euler_from_quat(quaternion: FloatArray, mount: str = "thesis") -> FloatArray:
    """Inverse of :func:`quat_from_euler`: ``(psi, theta, phi)`` with theta in [-pi/2, pi/2].

    Uses ``R = Rx(phi) Ry(theta) Rz(psi)``: ``R[0,2] = sin(theta)``,
    ``R[0,1] = -cos(theta) sin(psi)``, ``R[0,0] = cos(theta) cos(psi)``,
    ``R[1,2] = -sin(phi) cos(theta)``, ``R[2,2] = cos(phi) cos(theta)``.
    At gimbal lock (``cos(theta) = 0``) psi is set to 0.
    """
    from dexlfd.rotations import matrix_from_quat, quat_conjugate

    q = np.asarray(quaternion, dtype=np.float64)
    R = matrix_from_quat(quat_multiply(q, quat_conjugate(mount_quat(mount))))
    theta = np.arcsin(np.clip(R[..., 0, 2], -1.0, 1.0))
    c = np.cos(theta)
    locked = c < 1e-9
    psi = np.where(locked, 0.0, np.arctan2(-R[..., 0, 1], R[..., 0, 0]))
    phi = np.where(
        locked, np.arctan2(R[..., 2, 1], R[..., 1, 1]), np.arctan2(-R[..., 1, 2], R[..., 2, 2])
    )
    return np.stack([psi, theta, phi], axis=-1)


def gripper_opening(keypoints: FloatArray) -> FloatArray:
    """Thumb-tip to index-tip distance ``d_ti`` [m] (Eq. 4.14), shape ``(...,)``."""
    kp = np.asarray(keypoints, dtype=np.float64)
    return np.linalg.norm(kp[..., THUMB_TIP, :] - kp[..., INDEX_TIP, :], axis=-1)  # (4.14)


def _rigid_matrix(kp: FloatArray, hand: str, mode: str) -> FloatArray:
    """Hand rotation of the "triad" or "palm" mode; NaN rows stay NaN."""
    R = (
        palm_matrix_from_keypoints(kp, hand)
        if mode == "palm"
        else hand_matrix_from_keypoints(kp, hand)
    )
    return R


def unwrap_valid(angles: FloatArray) -> FloatArray:
    """Unwrap angles ``(n, k)`` along time over the finite rows, keeping NaN rows."""
    a = np.array(angles, dtype=np.float64, copy=True)
    ok = np.isfinite(a).all(axis=-1)
    if ok.sum() > 1:
        a[ok] = np.unwrap(a[ok], axis=0)
    return a


def pose_from_keypoints(
    keypoints: FloatArray, hand: str = "right", mount: str = "thesis", mode: str = "heading"
) -> PoseSeries:
    """Position, Euler angles, quaternion and gripper opening of every frame.

    Parameters
    ----------
    keypoints : ndarray, shape (n, 21, 3) or (21, 3)
        Landmarks in the base frame [m]; NaN rows give NaN outputs.
    hand : {"right", "left"}
    mount : str
        Key of ``MOUNTS``: the fixed hand-to-gripper rotation.
    mode : {"heading", "thesis", "triad", "palm"}
        Pitch/roll convention of :func:`euler_from_keypoints`; "triad" and "palm"
        take the quaternion from :func:`hand_matrix_from_keypoints` or
        :func:`palm_matrix_from_keypoints` (Euler angles derived from it, display only).

    Returns
    -------
    PoseSeries
        For a series (n, 21, 3): Euler angles unwrapped over time and
        quaternions sign-continuous; for one frame (21, 3): raw values.
    """
    kp = np.asarray(keypoints, dtype=np.float64)
    if kp.shape[-2:] != (21, 3):
        raise InvalidInput(f"keypoints must have shape (..., 21, 3), got {kp.shape}")
    position = kp[..., WRIST, :].copy()  # (4.10)
    if mode in ("triad", "palm"):
        quat = quat_multiply(quat_from_matrix(_rigid_matrix(kp, hand, mode)), mount_quat(mount))
        euler = euler_from_quat(quat, mount)
        if kp.ndim == 3:
            euler = unwrap_valid(euler)
    else:
        euler = euler_from_keypoints(kp, hand, mode)
        if kp.ndim == 3:
            euler = unwrap_valid(euler)
        quat = quat_from_euler(euler, mount)
    if kp.ndim == 3:
        quat = quat_sign_continuous(quat)
    return PoseSeries(position, euler, quat, gripper_opening(kp))
