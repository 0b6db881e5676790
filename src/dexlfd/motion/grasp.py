"""Grasp state from the gripper opening, with hysteresis (thesis Section 4.2.3).

The thesis grasps when the thumb-index distance ``d_ti`` falls below
``d_bar = 0.1 m``. A bare threshold chatters when ``d_ti`` hovers near it, so the
state switches on below ``threshold`` and off only above ``threshold +
hysteresis`` (a Schmitt trigger). Unseen frames (NaN) hold the previous state.

References
----------
.. [1] Thesis, Section 4.2.3, Eq. (4.14) and the threshold ``d_bar``.
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import as_float_array, check_positive

__all__ = ["grasp_state"]


def grasp_state(
    gripper: FloatArray,
    threshold: float = 0.1,
    hysteresis: float = 0.01,
    initial: bool = False,
) -> BoolArray:
    """Grasp flags from an opening series.

    Parameters
    ----------
    gripper : ndarray, shape (n,)
        Thumb-index distance [m]; NaN where unseen.
    threshold : float
        Grasp starts when the opening is below this [m] (thesis: 0.1).
    hysteresis : float
        Grasp ends only when the opening exceeds ``threshold + hysteresis`` [m], >= 0.
    initial : bool
        State before the first sample.

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    g = as_float_array(gripper, "gripper", ndim=1)
    threshold = check_positive(threshold, "threshold")
    hysteresis = check_positive(hysteresis, "hysteresis", strict=False)
    below = g < threshold
    above = g > threshold + hysteresis
    # state = last decisive event (below -> True, above -> False) at or before each sample
    event = np.where(below, 1, np.where(above, 0, -1))
    idx = np.where(event >= 0, np.arange(g.size), -1)
    last = np.maximum.accumulate(idx) if g.size else idx
    out = np.where(last >= 0, event[np.maximum(last, 0)] == 1, bool(initial))
    return out.astype(bool)
