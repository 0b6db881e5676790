"""Descend once onto the goal: a planned path's height never rises again after its top.

A learned carry replayed to a goal higher (relative to its start) than the person's
can come down past the goal and climb back to it: the forcing term reproduces the
person's descent in absolute terms, the spring to the goal pulls the path back up at
the end. Seen on a real take (a can taken off a shelf 0.29 m above the table, the
robot's pick and place both on the table): the carry went down to the table 2.6 s
before its end, 40 mm under the point above the place, and climbed back to it before
the vertical set-down, so the robot set the object down, lifted it 4 cm and set it
down again. A person comes down once.

:func:`descend_once` makes the height from the path's highest point to its end
non-increasing. Each stretch under a height the path climbs back to later is
bridged (:func:`descent_bridges`): a quintic from the path's position, velocity and
acceleration before the stretch brakes to rest at that height, holds it, and a
second quintic takes the path's own descent up again after it (so the bridged path
is as smooth as the planned one). The brake starts as late, and the descent resumes
as early, as a quintic fits that descends all the way, is no harsher than the
path's descent, and stays on or above the planned path (the path is only ever
lifted, like the floor of :mod:`dexlfd.plan.floor`: nothing under it is approached
nearer).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import numpy as np

from dexlfd._types import FloatArray

__all__ = ["RISE_TOL", "climbs_back", "descend_once", "descent_bridges"]

Path3 = tuple[FloatArray, FloatArray, FloatArray]
Arrays3 = tuple[FloatArray, FloatArray, FloatArray]
State = tuple[float, float, float]  # height, slope, curvature (per normalised time)

RISE_TOL = 5e-4  # [m] a path that climbs back less than this is descending already
_STARTS = 40  # bridge starts (and ends) tried, evenly between the stretch and the top
_CHECK = 500  # samples a tried bridge is checked at (the chosen one at every sample)
_FINE = np.linspace(0.0, 1.0, 65)  # where a bridge's slope and curvature are checked
_UP_TOL = 1e-4  # [m per normalised time] a bridge "descends" when it rises no faster


def _quintic(u: FloatArray, D: float, a: State, b: State) -> Arrays3:
    """Quintic over ``u`` in [0, 1] (duration ``D``) from ``a`` to ``b`` (value, slope, curvature).

    Slopes and curvatures are per the unit ``u`` spans ``D`` of; so are the returned
    derivatives.
    """
    (z0, v0, a0), (z1, v1, a1) = a, b
    h, V0, V1, A0, A1 = z1 - z0, v0 * D, v1 * D, a0 * D * D, a1 * D * D
    c = (
        z0, V0, 0.5 * A0,
        10 * h - 6 * V0 - 4 * V1 - 1.5 * A0 + 0.5 * A1,
        -15 * h + 8 * V0 + 7 * V1 + 1.5 * A0 - A1,
        6 * h - 3 * V0 - 3 * V1 - 0.5 * A0 + 0.5 * A1,
    )  # fmt: skip
    q = c[0] + u * (c[1] + u * (c[2] + u * (c[3] + u * (c[4] + u * c[5]))))
    dq = c[1] + u * (2 * c[2] + u * (3 * c[3] + u * (4 * c[4] + u * 5 * c[5])))
    ddq = 2 * c[2] + u * (6 * c[3] + u * (12 * c[4] + u * 20 * c[5]))
    return q, dq / D, ddq / (D * D)


_Fit = tuple[int, int, Arrays3, float]  # samples from, to; the quintic; its peak |z''|


def _fit(tb: FloatArray, z: FloatArray, ends: tuple[int, int], a: State, b: State) -> _Fit | None:
    """The quintic from ``a`` to ``b`` over samples ``ends``, and its peak ``|z''|``.

    None unless it descends (on a fine grid of its own) and stays on or above ``z``
    (tried at ``_CHECK`` samples, then checked at every one).
    """
    i, j = ends
    D = float(tb[j] - tb[i])
    _, dq, ddq = _quintic(_FINE, D, a, b)
    if dq.max() > _UP_TOL:
        return None
    s = slice(i, j + 1, max(1, (j - i) // _CHECK))
    if np.any(_quintic((tb[s] - tb[i]) / D, D, a, b)[0] < z[s] - 1e-9):
        return None
    q, dq_s, ddq_s = _quintic((tb[i : j + 1] - tb[i]) / D, D, a, b)
    if (
        dq_s.max() > _UP_TOL
        or np.diff(q).max(initial=0.0) > 1e-12
        or np.any(q < z[i : j + 1] - 1e-9)
    ):
        return None
    return i, j, (q, dq_s, ddq_s), float(np.abs(ddq).max())


def _first(groups: Iterator[list[_Fit]], bounds: tuple[float, float]) -> _Fit | None:
    """The gentlest (smallest peak ``|z''|``) fit of the first group with one within a bound.

    The first bound tried over the groups (made as they are needed), then the
    second; None when none is within.
    """
    seen: list[_Fit | None] = []  # each group's gentlest
    for bound in bounds:
        for i in itertools.count():
            if i == len(seen):
                group = next(groups, None)
                if group is None:
                    break
                seen.append(min(group, key=lambda f: f[3], default=None))
            best = seen[i]
            if best is not None and best[3] <= bound:
                return best
    return None


Bridge = tuple[int, int, Arrays3]  # samples from, to; the height and its derivatives


def _runs(z: FloatArray, p: int) -> list[tuple[int, int]]:
    """The stretches after ``p`` that climb back more than :data:`RISE_TOL`, as sample pairs.

    Each from the last sample before it to the first after it that are on the way
    down (at a height the path never climbs above again); overlapping ones merged.
    """
    later_max = np.maximum.accumulate(z[p:][::-1])[::-1]
    on = np.flatnonzero(z[p:] >= later_max) + p  # the end always is
    under = z[p:] < later_max - RISE_TOL
    starts = np.flatnonzero(under & ~np.concatenate([[False], under[:-1]])) + p
    runs: list[tuple[int, int]] = []
    for s in starts:
        a, b = int(on[on < s][-1]), int(on[on > s][0])
        if runs and a < runs[-1][1]:
            a = runs.pop()[0]
        runs.append((a, b))
    return runs


def _bridge(
    tb: FloatArray, z: FloatArray, zd: FloatArray, zdd: FloatArray, run: tuple[int, int],
    room: tuple[int, int],
) -> Bridge | None:  # fmt: skip
    """The bridge over ``run`` (:func:`_runs`) within the samples ``room``, or None."""
    (a, b), (lo, hi), n = run, room, z.shape[0]
    rest: State = (float(z[b]), 0.0, 0.0)
    # no harsher than the descent kept before the stretch, else than the whole path
    bounds = (float(np.abs(zdd[lo : a + 1]).max()), float(np.abs(zdd).max()))

    def at(i: int) -> State:
        return float(z[i]), float(zd[i]), float(zdd[i])

    brake = _first(
        (
            [f for m in _spread(a + 1, b) if (f := _fit(tb, z, (k, m), at(k), rest))]
            for k in _spread(lo, a)[::-1]
        ),
        bounds,
    )  # the latest start first
    if brake is None:
        return None
    k, m, curve, _ = brake
    e, resume = b, None
    if b < n - 1:  # the path descends further after it climbed back: resume that
        resume = _first(
            (
                [f for j in _spread(m + 1, e - 1) if (f := _fit(tb, z, (j, e), rest, at(e)))]
                for e in _spread(b + 1, hi)
            ),
            bounds,
        )  # the earliest end first
        if resume is None:
            return None
        e = resume[1]
    hold = (n - 1 if resume is None else resume[0] - 1) - m  # at rest between them
    pieces = [curve, (np.full(hold, rest[0]), np.zeros(hold), np.zeros(hold))]
    pieces += [] if resume is None else [resume[2]]

    def joined(i: int) -> FloatArray:
        return np.concatenate([c[i] for c in pieces])

    return k, e, (joined(0), joined(1), joined(2))


def descent_bridges(
    tb: FloatArray, z: FloatArray, zd: FloatArray, zdd: FloatArray
) -> tuple[list[Bridge], bool]:
    """The bridges that make ``z`` (n,) non-increasing after its top, and whether all fit.

    ``zd``, ``zdd`` are its derivatives per normalised time ``tb`` (n,). Over each
    stretch that climbs back by more than :data:`RISE_TOL` (:func:`_runs`) the bridge
    brakes the path's descent to rest at the height it climbs back to (a quintic),
    holds it and, unless the path climbs back to its end, resumes the path's descent
    after that (another quintic). The brake starts as late, and the descent resumes
    as early, as a quintic fits that descends, stays on or above ``z`` and is no
    harsher (peak ``|z''|``) than the descent kept before the stretch (failing that,
    than the whole path); of those the gentlest. A stretch
    that no bridge fits is bridged together with the next; one that still does not
    is left as planned (False). Returns the bridged samples ``k..e`` and the height
    and its derivatives there, per bridge.
    """
    n, p = z.shape[0], int(np.argmax(z))
    runs, bridges, lo, ok = _runs(z, p), [], p, True
    while runs:
        run = runs.pop(0)
        hi = runs[0][0] if runs else n - 1
        bridge = _bridge(tb, z, zd, zdd, run, (lo, hi))
        if bridge is not None:
            bridges.append(bridge)
            lo = bridge[1]
        elif runs:
            runs[0] = (run[0], runs[0][1])  # together with the next
        else:
            ok = False
    return bridges, ok


def _spread(i: int, j: int) -> list[int]:
    """At most ``_STARTS`` sample indices evenly from ``i`` to ``j`` (both in), increasing."""
    if j < i:
        return []
    return [int(v) for v in np.unique(np.linspace(i, j, min(j - i + 1, _STARTS)).round())]


def climbs_back(z: FloatArray) -> float:
    """How far [m] ``z`` (n,) climbs back up, at most, after its highest sample."""
    tail = z[int(np.argmax(z)) :]
    return float((np.maximum.accumulate(tail[::-1])[::-1] - tail).max())


def descend_once(tb: FloatArray, path: Path3) -> tuple[Path3, float, bool]:
    """``path`` (x, x', x'' (n, 3) per normalised time ``tb``) descending once after its top.

    Returns the path, the largest lift [m] a bridge made (0.0 when none was needed)
    and whether every stretch that climbed back was bridged (a stretch no bridge fits
    is kept as planned). See :func:`descent_bridges`.
    """
    bridges, ok = descent_bridges(tb, path[0][:, 2], path[1][:, 2], path[2][:, 2])
    if not bridges:
        return path, 0.0, ok
    x, xd, xdd = (np.array(a, dtype=np.float64, copy=True) for a in path)
    lift = 0.0
    for k, e, (q, dq, ddq) in bridges:
        lift = max(lift, float((q - x[k : e + 1, 2]).max()))
        x[k : e + 1, 2], xd[k : e + 1, 2], xdd[k : e + 1, 2] = q, dq, ddq
    return (x, xd, xdd), lift, ok
