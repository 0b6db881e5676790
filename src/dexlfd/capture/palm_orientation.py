"""The palm's orientation over a recording: trusted frames set it, the others are filled.

Frames whose palm is cut by the border, seen edge-on, of low confidence or
inconsistent do not set the orientation; neither does a run of trusted frames that
turns more than a limit away from the orientation kept around it (a flip,
:func:`drop_spikes`). Every other valid frame gets the slerp between the frames that
set it, held at the ends (:func:`fill_rotations`).
"""

from __future__ import annotations

import math

import numpy as np

from dexlfd._types import BoolArray, FloatArray, IntArray

__all__ = ["drop_spikes", "fill_rotations", "palm_orientation", "rotation_to"]


def rotation_to(d: FloatArray) -> FloatArray:
    """Smallest rotations ``(n, 3, 3)`` taking the optical axis (0, 0, 1) onto unit ``d``."""
    axis = np.stack([-d[:, 1], d[:, 0], np.zeros(len(d))], axis=1)  # e_z x d
    s = np.linalg.norm(axis, axis=1)
    c = d[:, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(s[:, None] > 1e-12, axis / s[:, None], 0.0)
    Kx = np.zeros((len(d), 3, 3))
    Kx[:, 0, 1], Kx[:, 0, 2] = -k[:, 2], k[:, 1]
    Kx[:, 1, 0], Kx[:, 1, 2] = k[:, 2], -k[:, 0]
    Kx[:, 2, 0], Kx[:, 2, 1] = -k[:, 1], k[:, 0]
    eye = np.broadcast_to(np.eye(3), Kx.shape)
    return np.asarray(eye + s[:, None, None] * Kx + (1 - c)[:, None, None] * (Kx @ Kx))


def _angle(Ra: FloatArray, Rb: FloatArray) -> FloatArray:
    """Angles [rad] between rotations ``(..., 3, 3)``."""
    tr = np.einsum("...ij,...ij->...", Ra, Rb)
    return np.asarray(np.arccos(np.clip((tr - 1.0) / 2.0, -1.0, 1.0)))


def _slerp(Ra: FloatArray, Rb: FloatArray, s: float) -> FloatArray:
    """The rotation a fraction ``s`` of the way from ``Ra`` to ``Rb``."""
    from dexlfd.rotations import (
        matrix_from_quat,
        quat_conjugate,
        quat_exp,
        quat_from_matrix,
        quat_log,
        quat_multiply,
    )

    qa, qb = quat_from_matrix(Ra), quat_from_matrix(Rb)
    if float(np.dot(qa, qb)) < 0:
        qb = -qb
    rel = quat_multiply(quat_conjugate(qa), qb)
    return np.asarray(matrix_from_quat(quat_multiply(qa, quat_exp(s * quat_log(rel)))))


def drop_spikes(rot: FloatArray, set_mask: BoolArray, max_step: float) -> BoolArray:
    """Unset the trusted frames whose orientation is a flip away from the others.

    The trusted frames are split into runs wherever consecutive ones turn by more
    than ``max_step``. The longest run is kept; going outwards from it, a run is kept
    when its first (last) frame is within ``max_step * sqrt(gap)`` of the last kept
    frame (``gap`` counted in frames), otherwise it is unset: a flip of one frame or a
    few between consistent ones, or a stretch whose world landmarks flipped, loses
    the flipped frames only.
    """
    out = set_mask.copy()
    ids = np.flatnonzero(out)
    if ids.size < 2:
        return out
    step = _angle(rot[ids[1:]], rot[ids[:-1]])
    runs = np.split(ids, np.flatnonzero(step > max_step) + 1)
    if len(runs) == 1:
        return out
    k0 = max(range(len(runs)), key=lambda k: runs[k].size)

    def close(a: int, b: int) -> bool:
        return bool(_angle(rot[a], rot[b]) <= max_step * math.sqrt(abs(b - a)))

    last = int(runs[k0][-1])
    for run in runs[k0 + 1 :]:
        if close(last, int(run[0])):
            last = int(run[-1])
        else:
            out[run] = False
    first = int(runs[k0][0])
    for run in reversed(runs[:k0]):
        if close(int(run[-1]), first):
            first = int(run[0])
        else:
            out[run] = False
    return out


def fill_rotations(rot: FloatArray, set_mask: BoolArray, ok: BoolArray) -> FloatArray:
    """Valid frames without a set orientation: slerp between the set ones around, or held."""
    out = rot.copy()
    ids = np.flatnonzero(set_mask)
    if not ids.size:
        return out
    for i in np.flatnonzero(ok & ~set_mask):
        k = int(np.searchsorted(ids, i))
        if k == 0:
            out[i] = rot[ids[0]]
        elif k == ids.size:
            out[i] = rot[ids[-1]]
        else:
            a, b = ids[k - 1], ids[k]
            out[i] = _slerp(rot[a], rot[b], (i - a) / (b - a))
    return out


def palm_orientation(
    R_cam: FloatArray,
    idx: IntArray,
    ok: BoolArray,
    usable: BoolArray,
    trusted: BoolArray,
    cos_world: FloatArray,
    max_step: float,
) -> tuple[FloatArray, BoolArray]:
    """The palm's rotation in every valid frame, and where the frame's own fit set it.

    Parameters
    ----------
    R_cam : ndarray, shape (m, 3, 3)
        Each valid frame's own palm rotation (template -> camera).
    idx : ndarray of int, shape (m,)
        The valid frames' indices among the recording's ``n`` frames.
    ok : ndarray of bool, shape (n,)
        The valid frames.
    usable, trusted : ndarray of bool, shape (m,)
        Frames not cut by the border nor of low confidence; and of those, the ones
        also neither edge-on nor inconsistent.
    cos_world : ndarray, shape (m,)
        ``|cos|`` of the palm normal's angle to the viewing ray.
    max_step : float
        The turn between consecutive trusted frames that marks a flip [rad].

    Returns
    -------
    (rotation, orientation_set) : ndarray (n, 3, 3), ndarray of bool (n,)
        Rotations (NaN where not valid) and the frames that set them.
    """
    n = ok.size
    rot = np.full((n, 3, 3), np.nan)
    rot[idx] = R_cam
    if not trusted.any():  # every frame edge-on or doubtful: the most face-on uncut ones
        if not usable.any():
            usable = np.ones(len(idx), bool)  # all cut or doubtful: the flips still go
        trusted = usable & (cos_world >= np.percentile(cos_world[usable], 90))
    set_mask = np.zeros(n, bool)
    set_mask[idx[trusted]] = True
    set_mask = drop_spikes(rot, set_mask, max_step)
    return fill_rotations(rot, set_mask, ok), set_mask
