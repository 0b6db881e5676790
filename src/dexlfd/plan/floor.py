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
    along minimum-jerk profiles of at most :data:`RAMP` each. Zero everywhere when ``z``
    never goes below ``floor``. The ends must be above the floor (a path that starts or
    ends below it cannot be lifted without moving its ends: ``ValueError``).

    A dip that runs into an end (a path that ends on the floor, coming up from below
    it) is not lifted by a ramp squeezed into the samples left after it: that ramp
    would move the path by the whole dip in a few milliseconds (seen on a real carry:
    a place at the edge of the top-down reach, approached from 8.7 cm inside it, gave
    5000 m/s^2 over the last 10 ms). There the ramp is the widest, at most
    :data:`RAMP` and not before the deepest dip, that still keeps ``z + L >= floor``
    on the way to that end (the lift eases down as the path comes up).
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
    deepest = int(np.argmax(deficit))
    b, w_out = _ramp_out(tb, deficit, depth, int(below[-1]), deepest)
    # the ramp in: the same, in reversed time
    rev = float(tb[0]) + float(tb[-1]) - tb[::-1]
    n = tb.shape[0]
    a_rev, w_in = _ramp_out(rev, deficit[::-1], depth, n - 1 - int(below[0]), n - 1 - deepest)
    a = float(tb[0]) + float(tb[-1]) - a_rev
    s_in, ds_in, dds_in = minimum_jerk((tb - (a - w_in)) / w_in)
    s_out, ds_out, dds_out = minimum_jerk((tb - b) / w_out)
    lift = depth * (s_in - s_out)
    d_lift = depth * (ds_in / w_in - ds_out / w_out)
    dd_lift = depth * (dds_in / w_in**2 - dds_out / w_out**2)
    return lift, d_lift, dd_lift


def _ramp_out(
    tb: FloatArray, deficit: FloatArray, depth: float, last: int, deepest: int
) -> tuple[float, float]:
    """Start and width (normalised time) of the ramp down after the dip's ``last`` sample.

    At ``last`` with :data:`RAMP` when that fits before the end; nearer the end, the
    widest ramp down to the end, starting no earlier than the ``deepest`` sample, that
    still covers ``deficit`` (the one from ``last`` always does; :func:`floor_lift`).
    """
    end = float(tb[-1])
    if end - float(tb[last]) >= RAMP:
        return float(tb[last]), RAMP
    k = max(deepest, int(np.searchsorted(tb, end - RAMP)))
    while k < last:
        b = float(tb[k])
        after = tb > b
        s = minimum_jerk((tb[after] - b) / (end - b))[0]
        if np.all(depth * (1.0 - s) >= deficit[after] - 1e-12):
            return b, end - b
        k += 1
    return float(tb[last]), end - float(tb[last])


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
