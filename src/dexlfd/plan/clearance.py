"""Clearance: bend a planned path around obstacles and check that it clears them.

For each obstacle, :func:`avoid_obstacles` picks the side to pass it on
(:func:`pick_direction`), measures the intrusion ``h`` of the obstacle into the
nominal path (:func:`dexlfd.plan.obstacles.intrusion`) and adds the DMP's response
to a coupling along that side:

* ``shaped`` (default): :func:`dexlfd.plan.coupling.shape_coupling` solves for the
  coupling that clears the obstacle by the margin (plus the variance's extra
  clearance, at most ``margin + band``) and returns to the learned path;
* ``thesis``: Eqs. (5.6)-(5.7) as printed, ``u = c k2 nu k1 h``, which guarantees
  nothing (the push starts ``_LEAD`` DMP time constants early).

Each obstacle's record (``Plan.obstacle_passes``) holds the side used, the needed
lift, the Eq. (5.7) ``gain`` the coupling amounts to, the thesis weight ``k2 nu`` and
the displacement; :func:`check_clearance` adds the clearance reached.
:func:`check_above_table` refuses a plan pushed below the table.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.ndimage import maximum_filter1d, uniform_filter1d

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Obstacle
from dexlfd.panda import TABLE_Z
from dexlfd.plan.coupling import shape_coupling
from dexlfd.plan.dmp_config import DmpConfig
from dexlfd.plan.dmp_rollout import coupling_response
from dexlfd.plan.end_shaping import Path, Window
from dexlfd.plan.obstacles import direction_vector, distance, intrusion

__all__ = [
    "AvoidanceSettings",
    "avoid_obstacles",
    "check_above_table",
    "check_clearance",
    "pick_direction",
    "variance_terms",
]

logger = logging.getLogger(__name__)

_LEAD = 1.5  # the push starts this many DMP time constants (1/sqrt(Kb)) early


@dataclass(frozen=True, slots=True)
class AvoidanceSettings:
    """The :class:`~dexlfd.plan.PlanConfig` fields obstacle avoidance reads.

    ``margin``, ``band``, ``variance_clearance``, ``influence`` [m]; ``k1``, ``k2``,
    ``c`` thesis gains; ``variance_aware`` the variance term on (Eq. 5.7) or off
    (Eq. 5.6); ``enforce_clearance`` shaped (True) or thesis (False) coupling.
    """

    dmp: DmpConfig
    margin: float
    band: float
    variance_clearance: float
    influence: float
    k1: float
    k2: float
    c: float
    variance_aware: bool
    enforce_clearance: bool


def pick_direction(
    ob: Obstacle, p: FloatArray, margin: float, influence: float, phase: FloatArray | None = None
) -> tuple[str, FloatArray]:
    """Resolve ``auto``: the cheapest side that is not along the path's own motion.

    ``phase``: the path's normalised time (a :class:`~dexlfd.plan.obstacles.BoxUnion`'s
    parts stand over stretches of it).
    """
    if ob.direction != "auto":
        return ob.direction, direction_vector(ob.direction)
    best: tuple[float, str] | None = None
    tangent = np.gradient(p, axis=0)
    for name in ("+z", "+x", "-x", "+y", "-y"):
        n = direction_vector(name)
        _h, req = intrusion(ob, p, n, margin, influence, phase)
        if not req.any():
            continue
        tan = tangent[req > 0]
        speed = np.linalg.norm(tan, axis=1)
        moving = speed > 1e-12
        if moving.any() and np.mean(np.abs(tan[moving] @ n) / speed[moving]) > 0.7:
            continue  # pushing along the path's own direction does not pass it
        cost = float(req.max())
        if best is None or cost < best[0] - 1e-9:
            best = (cost, name)
    name = "+z" if best is None else best[1]
    return name, direction_vector(name)


def _lead(h: FloatArray, n_lead: int) -> FloatArray:
    """Forward-looking running maximum over ``n_lead`` samples, then a moving average.

    The maximum starts the push before the path reaches the obstacle; the average
    makes the profile continuous, so the coupled velocity has no jumps.
    """
    if n_lead < 1:
        return h
    size = 2 * (n_lead // 2) + 1
    ahead = maximum_filter1d(h, size=size, origin=-(size // 2), mode="nearest")
    return uniform_filter1d(ahead, size=size, mode="nearest")


def _shaped_push(
    s: AvoidanceSettings,
    tb: FloatArray,
    h: FloatArray,
    req: FloatArray,
    nu: FloatArray,
    window: Window,
    velocity: FloatArray,
    speed_cap: float,
) -> tuple[Path, float, bool]:
    """Displacement (along the side) of the shaped coupling, its Eq. (5.7) gain, band met.

    The gain is the coupling's peak over ``c k1`` times the peak intrusion: the
    ``k2 nu`` the thesis's law would need to push that hard. The flag is False when
    the coupling could not keep under ``margin + band`` everywhere over the obstacle
    (:func:`check_clearance` then measures and reports the clearance).
    """
    sc = shape_coupling(
        s.dmp, tb, req, nu, window, kappa=s.variance_clearance, band=s.band,
        lead=_LEAD / np.sqrt(s.dmp.K_bar), velocity=velocity, speed_cap=speed_cap,
    )  # fmt: skip
    h_peak = float(h.max())
    gain = float(np.abs(sc.u).max()) / (s.c * s.k1 * h_peak) if h_peak > 0 else 0.0
    return (sc.x, sc.xd, sc.xdd), gain, sc.band_met


def _thesis_push(
    s: AvoidanceSettings, tb: FloatArray, h: FloatArray, w: FloatArray, window: Window
) -> tuple[Path, float]:
    """Eqs. (5.6)-(5.7) as printed: ``u = c k2 nu k1 h``, faded out by the end window.

    The variance is the one where the path meets the obstacle; the lead starts the
    push earlier. Returns the displacement along the side and the gain ``max w``.
    """
    n = tb.shape[0]
    n_lead = int(round(_LEAD / np.sqrt(s.dmp.K_bar) * (n - 1)))
    u = s.c * _lead(w * s.k1 * h, n_lead)  # Eq. (5.7)
    rx, rxd, rxdd = (r[:, 0] for r in coupling_response(s.dmp, n, u[:, None]))
    win, dwin, ddwin = window
    path = (rx * win, rxd * win + rx * dwin, rxdd * win + 2 * rxd * dwin + rx * ddwin)
    return path, float(w[h > 0].max())


def _record(
    ob: Obstacle, side: str, h: FloatArray, req: FloatArray, nu: FloatArray, w: FloatArray
) -> dict[str, Any]:
    """The obstacle's record (``Plan.obstacle_passes``) before it is passed."""
    info: dict[str, Any] = {
        **ob.to_dict(),
        "direction_used": side,
        "max_intrusion": float(h.max()),
        "required_lift": float(req.max()),
    }
    over = req > 0
    if over.any():
        info["variance_level"] = float(nu[over].max())
        info["thesis_weight"] = float(w[over].max())
    return info


def variance_terms(
    s: AvoidanceSettings, variance: Callable[[FloatArray], FloatArray], n: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Normalised variance ``nu`` along ``n`` and the thesis weight ``k2 nu`` (Eq. 5.7).

    With the variance term off: ``nu = 0`` and the weight 1 (Eq. 5.6).
    """
    if not s.variance_aware:
        ones = np.ones_like(variance(n))
        return 0.0 * ones, ones
    nu = variance(n)
    return nu, s.k2 * nu


def avoid_obstacles(
    obstacles: tuple[Obstacle, ...],
    s: AvoidanceSettings,
    tb: FloatArray,
    path: Path,
    variance: Callable[[FloatArray], FloatArray],
    window: Window,
) -> tuple[Path, list[dict[str, Any]], tuple[FloatArray, FloatArray]]:
    """Add each obstacle's displacement to the nominal ``path`` (x, xd, xdd per tb).

    ``variance(n)`` gives the normalised variance ``nu`` (n_samples,) along a unit
    direction ``n`` on the grid ``tb``
    (:func:`dexlfd.plan.obstacles.variance_level`); ``window`` is the end window.
    Returns the bent path, one record per obstacle (see the module docstring) and
    ``nu`` with the thesis weight ``k2 nu`` along the first obstacle's side (``+z``
    without obstacles), for the plan's extras.
    """
    nominal, x, xd, xdd = path[0].copy(), *path
    # avoiding must not make the motion faster than the demonstrated one
    nominal_speed = float(np.linalg.norm(xd, axis=1).max())
    records: list[dict[str, Any]] = []
    for i, ob in enumerate(obstacles):
        side, nvec = pick_direction(ob, nominal, s.margin, s.influence, tb)
        h, req = intrusion(ob, nominal, nvec, s.margin, s.influence, tb)
        nu, w = variance_terms(s, variance, nvec)
        info = _record(ob, side, h, req, nu, w)
        info["coupling"] = "shaped" if s.enforce_clearance else "thesis"
        push: Path | None = None
        if s.enforce_clearance and (req > 0).any():
            push, info["gain"], info["band_met"] = _shaped_push(
                s, tb, h, req, nu, window, xd @ nvec, nominal_speed
            )
            over = np.flatnonzero(req > 0)
            info["_over"] = (int(over[0]), int(over[-1]) + 1)  # check_clearance pops it
        elif not s.enforce_clearance and h.max() > 0:
            # shaped: a path that needs no lift is left alone (the thesis's push, fed
            # the fading intrusion beside an obstacle, lifted a real carry 0.9 m)
            push, info["gain"] = _thesis_push(s, tb, h, w, window)
        if push is not None:
            x, xd, xdd = (
                a + p[:, None] * nvec[None, :] for a, p in zip((x, xd, xdd), push, strict=True)
            )
            info["displacement"] = float(push[0].max())
            logger.info(
                "obstacle %d: %s coupling, gain %.3g (thesis weight %.3g), displacement "
                "%.3f m for a needed lift of %.3f m",
                i, info["coupling"], info["gain"], info.get("thesis_weight", 0.0),
                info["displacement"], req.max(),
            )  # fmt: skip
        records.append(info)
    first = direction_vector(records[0]["direction_used"] if records else "+z")
    return (x, xd, xdd), records, variance_terms(s, variance, first)


def check_above_table(x: FloatArray, nominal: FloatArray, records: list[dict[str, Any]]) -> None:
    """Refuse a plan that goes below the table (z = 0), naming what pushed it there."""
    z_min = float(x[:, 2].min())
    if z_min >= TABLE_Z:
        return
    down = [i for i, ob in enumerate(records) if ob["direction_used"] == "-z"]
    if down and float(nominal[:, 2].min()) >= TABLE_Z:
        raise InvalidInput(
            f"obstacle {down[0]} pushes the plan {1e3 * (TABLE_Z - z_min):.0f} mm below "
            f"the table (z = {TABLE_Z} m): pass it along another direction (@+z, @auto)"
        )
    raise InvalidInput(
        f"the plan goes {1e3 * (TABLE_Z - z_min):.0f} mm below the table (z = {TABLE_Z} "
        "m); move the start/goal or the obstacles"
    )


def check_clearance(
    obstacles: tuple[Obstacle, ...],
    x: FloatArray,
    nominal: FloatArray,
    margin: float,
    enforce: bool,
    records: list[dict[str, Any]],
    band: float | None = None,
    phase: FloatArray | None = None,
) -> FloatArray | None:
    """Check the final path ``x`` against the table and the obstacles.

    Refuses a path below the table (:func:`check_above_table`). Returns the
    clearance (n,) [m] from the nearest obstacle (None without obstacles), records
    each obstacle's ``min_clearance`` in ``records``, warns below ``margin`` and
    raises :class:`InvalidInput` for a collision when ``enforce``. Where the shaped
    coupling could not keep within ``margin + band`` [m] over an obstacle, the
    clearance measured there is reported (:func:`_report_band`). ``phase``: the path's
    normalised time (n,) (:func:`dexlfd.plan.obstacles.distance`).
    """
    check_above_table(x, nominal, records)
    if not obstacles:
        return None
    per = np.stack([distance(ob, x, phase) for ob in obstacles])
    for i, info in enumerate(records):
        info["min_clearance"] = float(per[i].min())
        if per[i].min() < margin - 1e-6:
            msg = (
                f"the plan passes {per[i].min():.3f} m from obstacle {i} "
                f"({obstacles[i].spec()}), less than the margin {margin} m"
            )
            if per[i].min() < 0 and enforce:
                raise InvalidInput(msg + "; it collides")
            logger.warning("%s", msg)
        over = info.pop("_over", None)
        if band is not None and over is not None and not info.get("band_met", True):
            _report_band(i, per[i][over[0] : over[1]], margin + band)
    return np.asarray(per.min(axis=0))


def _report_band(i: int, clearance: FloatArray, limit: float) -> None:
    """Say how far the path over obstacle ``i`` really passes when the band was relaxed.

    ``clearance`` [m] over the samples the coupling had to lift; ``limit`` [m] is
    ``margin + band``.
    """
    lo, hi = float(clearance.min()), float(clearance.max())
    if hi > limit + 1e-4:
        logger.warning(
            "obstacle %d: over it the path clears by %.3f..%.3f m, up to %.3f m more than "
            "margin + band (%.3f m): the coupling could not stay within the band",
            i, lo, hi, hi - limit, limit,
        )  # fmt: skip
    else:
        logger.info(
            "obstacle %d: the coupling's band bound was relaxed, yet the path clears it by "
            "%.3f..%.3f m, within margin + band (%.3f m)",
            i, lo, hi, limit,
        )  # fmt: skip
