"""A floor for a planned motion: the path is lifted above it where it dips, not refused.

A learned motion replayed between new ends can dip lower than its ends: a person's
carry that sagged between the lift and the set-down, moved to a pick on the table,
passes a millimetre under it (seen on a real take: the carry 1 mm below the table).
The robot has no reason to copy that dip, and a held object must not scrape its
support, so :func:`lift_above_floor` raises the path over the stretch that dips by
the deepest dip, ramped in and out along minimum-jerk profiles (zero velocity and
acceleration where a ramp starts and ends): the lifted path is as smooth as the
planned one, keeps its ends, and is nowhere below the floor.
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.trajectory import minimum_jerk

__all__ = ["RAMP", "floor_lift", "lift_above_floor"]

RAMP = 0.2  # the longest ramp in and out of a lift, as a fraction of the motion's time


def floor_lift(tb: FloatArray, z: FloatArray, floor: float) -> tuple[FloatArray, ...]:
    """The lift ``L`` (n,) [m] that takes ``z`` (n,) above ``floor``, with ``L'`` and ``L''``.

    ``tb`` is the normalised time (0..1, increasing); derivatives are per normalised
    time. ``L`` is the deepest dip ``max(floor - z)`` over the samples below the floor
    and between them, and ramps from 0 before the first and back to 0 after the last
    along minimum-jerk profiles of at most :data:`RAMP` each (shorter when the dip is
    nearer an end). Zero everywhere when ``z`` never goes below ``floor``; ``z + L >=
    floor`` at every sample. The ends must be above the floor (a path that starts or
    ends below it cannot be lifted without moving its ends: ``ValueError``).
    """
    tb = np.asarray(tb, dtype=np.float64)
    deficit = float(floor) - np.asarray(z, dtype=np.float64)
    zero = np.zeros_like(tb)
    below = np.flatnonzero(deficit > 0)
    if below.size == 0:
        return zero, zero.copy(), zero.copy()
    if below[0] == 0 or below[-1] == tb.shape[0] - 1:
        raise ValueError("the path starts or ends below the floor")
    depth = float(deficit[below].max())
    a, b = float(tb[below[0]]), float(tb[below[-1]])
    w_in, w_out = min(RAMP, a - float(tb[0])), min(RAMP, float(tb[-1]) - b)
    s_in, ds_in, dds_in = minimum_jerk((tb - (a - w_in)) / w_in)
    s_out, ds_out, dds_out = minimum_jerk((tb - b) / w_out)
    lift = depth * (s_in - s_out)
    d_lift = depth * (ds_in / w_in - ds_out / w_out)
    dd_lift = depth * (dds_in / w_in**2 - dds_out / w_out**2)
    return lift, d_lift, dd_lift


def lift_above_floor(
    tb: FloatArray, path: tuple[FloatArray, FloatArray, FloatArray], floor: float | None
) -> tuple[tuple[FloatArray, FloatArray, FloatArray], float]:
    """``path`` (x, x', x'') per normalised time ``tb`` lifted above ``floor`` [m] in z.

    Returns the path and the lift's peak [m] (0.0 when nothing dipped or ``floor`` is
    None). The path's own ends stay where they are: an end below ``floor`` lowers the
    floor to it. See :func:`floor_lift`.
    """
    if floor is None:
        return path, 0.0
    x, xd, xdd = (np.array(p, dtype=np.float64, copy=True) for p in path)
    floor = min(float(floor), float(x[0, 2]), float(x[-1, 2]))
    lift, d_lift, dd_lift = floor_lift(tb, x[:, 2], floor)
    x[:, 2] += lift
    xd[:, 2] += d_lift
    xdd[:, 2] += dd_lift
    return (x, xd, xdd), float(lift.max())
