"""Obstacles and the variance-aware Gams coupling term (Eqs. 5.6-5.7).

Obstacles are axis-aligned boxes (centre, edge lengths) and spheres (centre, radius)
in the robot base frame [m]. Each is passed on one side, along an *avoidance
direction* ``n`` (default ``+z``: over the top, as the thesis's demonstrations do;
``+x``, ``-x``, ``+y``, ``-y``, ``-z`` or ``auto``).

The intrusion h(t)
------------------
The thesis calls ``h`` "the obstacle dimensions" and plots it as a block over time
(Fig. 5.5). We define it as the obstacle's intrusion into the *nominal* path (the
DMP rollout without obstacles) ``p(t)``, measured along ``n``::

    h(t) = lambda(p(t)) * phi(p(t))

* ``lambda`` [m]: how far ``p`` must move along ``n`` to be ``margin`` away from the
  obstacle (Euclidean distance: the obstacle inflated by ``margin`` has rounded
  edges, so a point beside a box needs less lift than one over it; 0 if the point is
  already past it);
* ``phi`` in [0, 1]: 1 within ``margin`` of the obstacle's shadow along ``n`` (the
  footprint, for ``+z``), falling smoothly (cubic smoothstep) to 0 at the
  ``influence`` distance beyond it, so ``h`` is continuous in time.

Pushing along ``n`` leaves the other two coordinates unchanged, so ``lambda``
computed on the nominal path is exactly the lift the path needs at time ``t``.

Variance (Eq. 5.7)
------------------
The thesis scales the coupling by ``k2 cbrt(|Sigma|)`` but gives no unit for
``|Sigma|``; any fixed unit makes the term meaningless for a model whose
demonstrations disagree by millimetres or by decimetres. :func:`variance_level`
measures it against the model's own spread, keeping Eq. (5.7)'s proportionality::

    nu(t) = v(t) / max_t v(t),    v(t) = n^T Sigma_p(t) n

``v`` is the variance along the avoidance direction ``n`` (the thesis bends and
plots the z axis; the demonstrators' disagreement across it says nothing about how
far to pass over an obstacle), ``cbrt(|Sigma_p|)`` (the geometric-mean variance of
the printed equation) when no direction is given. ``nu`` is 1 where the
demonstrations disagree most along ``n``, proportional to the variance elsewhere,
and the same for a model in metres or millimetres. The planner turns ``nu`` into
extra clearance (see :mod:`dexlfd.plan.coupling`).

An earlier reading, ``nu = v / (v + median v)`` with ``v = cbrt(|Sigma_p|)``,
compressed the demo model's contrast away: along z the demonstrations disagree
17 mm (std) over the cup and 4 mm at the lift-off, but the determinant mixes in
the x axis (0.5 mm at both) and the saturating map gave 0.83 vs 0.60.

References
----------
.. [1] Gams, Nemec, Ijspeert, Ude (2014), Coupling movement primitives: interaction
   with the environment and bimanual tasks, IEEE Trans. Robot. 30(4).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import (
    _AXES,
    Box,
    Obstacle,
    Sphere,
    signed_distance,
)

__all__ = [
    "BoxUnion",
    "direction_vector",
    "distance",
    "intrusion",
    "variance_level",
    "variance_weight",
]

logger = logging.getLogger(__name__)

_TOP = 0.9  # nu = 1 over the tenth of the movement where the demonstrations disagree most


@dataclass(frozen=True, slots=True)
class BoxUnion(Box):
    """An obstacle grown by the hand's room: a union of axis-aligned boxes.

    ``parts`` are the boxes (the obstacle grown by each cell of the hand,
    :func:`dexlfd.plan.envelope.grow`); ``phases``, one per part, the stretch
    ``(s0, s1)`` of the motion's normalised time [0, 1] over which it stands (the
    hand takes that cell's room at those orientations only then); None: all along.
    Its own ``center`` and ``size`` are the parts' bounding box: what code that does
    not know the parts (and :meth:`to_dict`) sees, a larger obstacle.
    """

    parts: tuple[Box, ...] = ()
    phases: tuple[tuple[float, float], ...] | None = None

    @classmethod
    def of(
        cls, parts: tuple[Box, ...], phases: tuple[tuple[float, float], ...] | None = None
    ) -> BoxUnion:
        """The union of ``parts`` (one side, the first's), over ``phases`` (one per part)."""
        if not parts or (phases is not None and len(phases) != len(parts)):
            raise ValueError("a union needs parts, and one phase per part when phased")
        lo = np.min([np.subtract(b.center, np.divide(b.size, 2)) for b in parts], axis=0)
        hi = np.max([np.add(b.center, np.divide(b.size, 2)) for b in parts], axis=0)
        return cls(tuple((lo + hi) / 2), tuple(hi - lo), parts[0].direction, parts, phases)

    def stands(self, phase: FloatArray | None, n: int) -> list[tuple[Box, np.ndarray]]:
        """Each part with the samples (bool (n,)) it stands at; every sample without phase."""
        if self.phases is None or phase is None:
            return [(b, np.ones(n, dtype=bool)) for b in self.parts]
        s = np.asarray(phase, dtype=np.float64)
        return [(b, (s >= s0) & (s <= s1)) for b, (s0, s1) in zip(self.parts, self.phases,
                                                                    strict=True)]  # fmt: skip


def distance(obstacle: Obstacle, p: FloatArray, phase: FloatArray | None = None) -> FloatArray:
    """Signed distance [m] of the points ``p`` (n, 3) from the obstacle (< 0 inside).

    A :class:`BoxUnion`: from the nearest part standing at each point's ``phase``
    (the motion's normalised time (n,); None: every part); inf where none stands.
    """
    p = np.atleast_2d(np.asarray(p, dtype=np.float64))
    if not isinstance(obstacle, BoxUnion) or not obstacle.parts:
        return signed_distance(obstacle, p)
    out = np.full(p.shape[0], np.inf)
    for box, at in obstacle.stands(phase, p.shape[0]):
        if at.any():
            out[at] = np.minimum(out[at], signed_distance(box, p[at]))
    return out


def direction_vector(direction: str) -> FloatArray:
    """Unit vector of ``+z``, ``-x``... (not ``auto``)."""
    n = np.zeros(3)
    n[_AXES[direction[1]]] = 1.0 if direction[0] == "+" else -1.0
    return n


def _fade(u: FloatArray) -> FloatArray:
    """1 for u <= 0, smooth (C1 cubic) to 0 at u >= 1."""
    x = np.clip(u, 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


def intrusion(
    obstacle: Obstacle, p: FloatArray, n: FloatArray, margin: float, influence: float,
    phase: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Intrusion ``h`` [m] of the obstacle into the path ``p`` (n_pts, 3) along ``n``.

    Returns ``(h, required)``: ``h = lambda * phi`` (see the module docstring) and
    ``required`` = ``lambda`` where the point is inside the obstacle's shadow inflated
    by ``margin`` (the lift needed for the clearance), else 0. A :class:`BoxUnion`:
    the largest of its parts' standing at each point's ``phase`` (the path's
    normalised time (n_pts,)): moved that far along ``n``, the point clears each.
    """
    p = np.asarray(p, dtype=np.float64)
    if isinstance(obstacle, BoxUnion) and obstacle.parts:
        h, req = np.zeros(p.shape[0]), np.zeros(p.shape[0])
        for box, at in obstacle.stands(phase, p.shape[0]):
            if at.any():
                hb, rb = intrusion(box, p[at], n, margin, influence)
                h[at], req[at] = np.maximum(h[at], hb), np.maximum(req[at], rb)
        return h, req
    c = np.asarray(obstacle.center)
    rel = p - c
    a = rel @ n
    if isinstance(obstacle, Sphere):
        R = obstacle.radius + margin
        perp2 = np.maximum(np.einsum("ij,ij->i", rel, rel) - a * a, 0.0)
        lam = np.maximum(-a + np.sqrt(np.maximum(R * R - perp2, 0.0)), 0.0)
        inside = perp2 <= R * R
        dist = np.linalg.norm(rel, axis=1) - R
        phi = np.where(inside & (dist <= 0), 1.0, _fade(np.maximum(dist, 0.0) / influence))
        required = np.where(inside & (a < R), lam, 0.0)
        return lam * phi, required
    half = 0.5 * np.asarray(obstacle.size)
    axis = int(np.argmax(np.abs(n)))
    others = [k for k in range(3) if k != axis]
    # lateral distance from the footprint (the box's shadow along n)
    rho = np.linalg.norm(np.maximum(np.abs(rel[:, others]) - half[others], 0.0), axis=1)
    # height over the face that keeps the Euclidean distance >= margin (rounded edge)
    above = half[axis] + np.sqrt(np.maximum(margin * margin - rho * rho, 0.0))
    lam = np.where(a >= -(half[axis] + margin), np.maximum(above - a, 0.0), 0.0)
    phi = _fade(np.maximum(rho - margin, 0.0) / influence)
    return lam * phi, np.where(rho < margin, lam, 0.0)


def variance_level(
    cov_p: FloatArray, n: FloatArray | None = None, scale: float | None = None
) -> FloatArray:
    """Variance level ``nu`` in [0, 1] along ``n`` (see the module docstring).

    With ``scale`` [m] (the metres measure): ``nu = min(1, sqrt(v) / scale)``, the
    demonstrations' standard deviation along ``n`` against a length, so the extra
    clearance ``scale * nu = min(scale, sigma_n)`` is their spread in metres: none
    where they agree, centimetres where they disagree by centimetres. Without
    (the relative measure): ``nu = min(1, v / v90)``, against the model's own 90th
    percentile.

    Parameters
    ----------
    cov_p : ndarray, shape (m, 3, 3)
        Positional GMR covariance over time [m²].
    n : ndarray, shape (3,), optional
        Unit avoidance direction: ``v = n^T Sigma_p n``; default ``v = cbrt(|Sigma_p|)``.

    Returns
    -------
    ndarray, shape (m,)
        In [0, 1]; 1 at the model's largest ``v``; all 0 for a model without variance.
    """
    if n is None:
        v = _cbrt_det(cov_p)
    else:
        n = np.asarray(n, dtype=np.float64)
        v = np.maximum(np.einsum("i,kij,j->k", n, cov_p, n), 0.0)
    if scale is not None:
        if not (np.isfinite(scale) and scale > 0):
            raise InvalidInput(f"variance scale must be > 0 [m], got {scale!r}")
        return np.asarray(np.minimum(np.sqrt(v) / scale, 1.0), dtype=np.float64)
    top = float(np.quantile(v, _TOP))
    if not top > 0.0:
        top = float(v.max())
    return np.minimum(v / top, 1.0) if top > 0.0 else np.zeros_like(v)


def _cbrt_det(cov_p: FloatArray) -> FloatArray:
    cov = 0.5 * (cov_p + np.swapaxes(cov_p, -1, -2))
    return np.cbrt(np.maximum(np.linalg.det(cov), 0.0))


def variance_weight(cov_p: FloatArray, k2: float, n: FloatArray | None = None) -> FloatArray:
    """Thesis weight ``w(t) = k2 nu(t)`` (Eq. 5.7) with ``nu`` from :func:`variance_level`.

    Parameters
    ----------
    cov_p : ndarray, shape (m, 3, 3)
        Positional GMR covariance [m²].
    k2 : float
    n : ndarray, shape (3,), optional
        Avoidance direction (see :func:`variance_level`).

    Returns
    -------
    ndarray, shape (m,)
    """
    return k2 * variance_level(cov_p, n)
