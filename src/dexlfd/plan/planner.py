"""Plan a new motion from a learned model: new start/goal, obstacles, duration.

:func:`plan_from_model` fits a modified DMP (Eq. 5.5) to the GMR mean position, a
quaternion DMP (Ude et al. 2014) to its orientation, plays the gripper channel back
on the learned schedule in phase, and bends the path around obstacles with the
variance-aware Gams coupling (Eqs. 5.6-5.7, :mod:`dexlfd.plan.obstacles`).

Obstacles: by default (``enforce_clearance=True``) the coupling is *shaped*
(:mod:`dexlfd.plan.coupling`): the path clears each obstacle by ``margin`` plus at
most ``band`` [m] over it, bends up to ``variance_clearance`` [m] further where the
demonstrations disagreed (the variance term of Eq. 5.7, measured against the model's
own spread) and returns to the learned path after it. ``enforce_clearance=False`` is
the thesis's law as printed, ``u = c k1 k2 nu(t) h(t)`` with the normalised variance
``nu``, which guarantees nothing. ``Plan.meta["obstacles"]`` records, per obstacle,
the gain the coupling amounts to in Eq. (5.7) (``gain``), the thesis weight
``k2 nu`` there, the displacement, the needed lift and the clearance.

References
----------
.. [1] Pastor, Hoffmann, Asfour, Schaal (2009), Learning and generalization of motor
   skills by learning from demonstration, ICRA.
.. [2] Ude, Nemec, Petric, Morimoto (2014), Orientation in Cartesian space dynamic
   movement primitives, ICRA.
.. [3] Gams, Nemec, Ijspeert, Ude (2014), Coupling movement primitives: interaction
   with the environment and bimanual tasks, IEEE Trans. Robot. 30(4).
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.ndimage import maximum_filter1d, uniform_filter1d

from dexlfd._types import FloatArray
from dexlfd._validation import check_positive
from dexlfd.errors import InvalidInput
from dexlfd.io import LearnedModel, Plan
from dexlfd.panda import GRIPPER_OPENING_MAX, TABLE_Z, check_workspace
from dexlfd.plan.coupling import shape_coupling
from dexlfd.plan.dmp import DmpConfig, _rollout_impl, coupling_response, fit_dmp
from dexlfd.plan.limits import check_cartesian_limits
from dexlfd.plan.obstacles import (
    Box,
    Obstacle,
    Sphere,
    direction_vector,
    intrusion,
    signed_distance,
    variance_level,
)
from dexlfd.plan.place import place_correction
from dexlfd.plan.quaternion_dmp import (
    _rotvec_between,
    fit_quaternion_dmp,
    rollout_quaternion_dmp,
)
from dexlfd.rotations import matrix_from_quat, quat_exp, quat_multiply, quat_sign_continuous

__all__ = ["PlanConfig", "check_model_covariance", "plan_from_model"]

logger = logging.getLogger(__name__)

_START_VELOCITY = ("model", "zero")
_ON_LIMIT = ("warn", "raise")
_GOAL_WARN = 5e-3  # [m] a larger DMP end residual is blended out with a warning
_LEAD = 1.5  # the push starts this many DMP time constants (1/sqrt(Kb)) early
MAX_SAMPLES = 3_600_001  # one hour at 1 kHz: larger plans are a typo, not a task

_SUPPORT_WIDTH = 0.1  # [m] footprint of the place support recorded for the simulator
_TAPER = 0.1  # the obstacle displacement fades out over the last 10 % of the movement
_COARSE = 300  # model grids with fewer samples are resampled (cubic spline) ...
_FIT_SAMPLES = 1000  # ... to this many before fitting


def _fit_grid(t: FloatArray, x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Resample a coarse model grid with a cubic spline for the DMP fit.

    The forcing target needs x''; finite differences on a coarse grid (a GMR evaluated
    at 50-200 times) lose centimetres, a C2 spline through the same points does not.
    """
    if t.shape[0] >= _COARSE:
        return t, x
    tf = np.linspace(t[0], t[-1], _FIT_SAMPLES)
    return tf, np.asarray(CubicSpline(t, x, axis=0)(tf), dtype=np.float64)


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


def _taper(tb: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Window 1 -> 0 (quintic smoothstep) over the last ``_TAPER`` of normalised time.

    Returns the window and its first two derivatives per normalised time.
    """
    u = np.clip((tb - (1.0 - _TAPER)) / _TAPER, 0.0, 1.0)
    S = u**3 * (10 - 15 * u + 6 * u**2)
    dS = 30 * u**2 * (1 - u) ** 2 / _TAPER
    ddS = (60 * u - 180 * u**2 + 120 * u**3) / _TAPER**2
    return 1.0 - S, -dS, -ddS


def _rest_correction(
    tb: FloatArray, v_end: FloatArray, a_end: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Correction over the last ``_TAPER`` that zeroes the final velocity/acceleration.

    Quintics in ``u`` with value, slope and curvature 0 at the window's start and
    value 0 at its end: ``p_v = -4u³ + 7u⁴ - 3u⁵`` (slope 1 at u = 1) and
    ``p_a = (u³ - 2u⁴ + u⁵)/2`` (curvature 1 at u = 1). Adding
    ``-L v_end p_v - L² a_end p_a`` (L = window length in normalised time) keeps
    the end position and makes the end velocity and acceleration 0; the
    derivatives are per normalised time, like ``v_end`` and ``a_end``.
    """
    L = _TAPER
    u = np.clip((tb - (1.0 - L)) / L, 0.0, 1.0)[:, None]
    p_v = -4 * u**3 + 7 * u**4 - 3 * u**5
    dp_v = -12 * u**2 + 28 * u**3 - 15 * u**4
    ddp_v = -24 * u + 84 * u**2 - 60 * u**3
    p_a = 0.5 * u**3 - u**4 + 0.5 * u**5
    dp_a = 1.5 * u**2 - 4 * u**3 + 2.5 * u**4
    ddp_a = 3 * u - 12 * u**2 + 10 * u**3
    v, a = v_end[None, :], a_end[None, :]
    dx = -L * v * p_v - L**2 * a * p_a
    dxd = -v * dp_v - L * a * dp_a
    dxdd = -v * ddp_v / L - a * ddp_a
    return dx, dxd, dxdd


def _opt_vec(value: Any, name: str, size: int) -> tuple[float, ...] | None:
    if value is None:
        return None
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{name} must be {size} numbers, got {value!r}") from exc
    if arr.shape != (size,) or not np.isfinite(arr).all():
        raise InvalidInput(f"{name} must be {size} finite numbers, got {value!r}")
    return tuple(float(v) for v in arr)


def _unit_quat(value: tuple[float, ...], name: str) -> tuple[float, ...]:
    q = np.asarray(value)
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > 1e-2:
        raise InvalidInput(f"{name} must be a unit quaternion (x, y, z, w), its norm is {norm:.4g}")
    if abs(norm - 1.0) > 1e-9:
        logger.warning("%s has norm %.6f; normalised to 1", name, norm)
    return tuple(float(v) for v in q / norm)


@dataclass(frozen=True)
class PlanConfig:
    """What to plan and how.

    Attributes
    ----------
    start, goal : tuple of 3 float, optional
        Start and goal position [m], base frame; default: the model's.
    start_quat, goal_quat : tuple of 4 float, optional
        Start and goal orientation (x, y, z, w); default: the model's.
    duration : float, optional
        Movement duration [s] (temporal scaling); default: the model's.
    rate_hz : float
        Output sample rate [Hz] (1 kHz matches the control loop).
    obstacles : tuple of Box/Sphere
    dmp : DmpConfig
        ``K``, ``D`` (thesis: 1, 1), basis functions, phase decay.
    k1, k2, c : float
        Coupling gains of Eqs. (5.6)-(5.7) (thesis: 10, 15, 1).
    variance_aware : bool
        Scale the coupling by the GMR variance (Eq. 5.7); False: Eq. (5.6).
    margin : float
        Clearance to keep from every obstacle [m].
    band : float
        The shaped coupling passes an obstacle by at most ``margin + band`` [m].
    variance_clearance : float
        Extra clearance [m] (``<= band``) where the demonstrations disagreed most
        (normalised variance 1); half of it at the model's median variance.
    influence : float
        Distance beyond the inflated obstacle over which the push fades in [m].
    enforce_clearance : bool
        Shape the coupling so the margin holds (see module doc); False: the thesis's
        proportional law, no guarantee.
    start_velocity : str
        ``"model"``: keep the GMR mean's initial velocity (rescaled to the duration);
        ``"zero"``: start at rest.
    on_limit : str
        ``"warn"`` (log and record in ``meta``) or ``"raise"`` when the plan exceeds
        the Panda's Cartesian limits.
    place_surface_z : float, optional
        Height of the surface under the place point [m]. Given, the held object is
        lowered onto it before the gripper opens (:mod:`dexlfd.plan.place`).
    object_bottom : float
        Distance from the TCP down to the held object's bottom [m] (the simulated
        box: its half height, 0.03 m).
    """

    start: tuple[float, ...] | None = None
    goal: tuple[float, ...] | None = None
    start_quat: tuple[float, ...] | None = None
    goal_quat: tuple[float, ...] | None = None
    duration: float | None = None
    rate_hz: float = 1000.0
    obstacles: tuple[Obstacle, ...] = ()
    dmp: DmpConfig = field(default_factory=DmpConfig)
    k1: float = 10.0
    k2: float = 15.0
    c: float = 1.0
    variance_aware: bool = True
    margin: float = 0.02
    band: float = 0.02
    variance_clearance: float = 0.015
    influence: float = 0.03
    enforce_clearance: bool = True
    start_velocity: str = "model"
    on_limit: str = "warn"
    place_surface_z: float | None = None
    object_bottom: float = 0.03

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", _opt_vec(self.start, "start", 3))
        object.__setattr__(self, "goal", _opt_vec(self.goal, "goal", 3))
        for name in ("start_quat", "goal_quat"):
            q = _opt_vec(getattr(self, name), name, 4)
            object.__setattr__(self, name, None if q is None else _unit_quat(q, name))
        if self.duration is not None:
            object.__setattr__(self, "duration", check_positive(self.duration, "duration [s]"))
        check_positive(self.rate_hz, "rate_hz")
        for name in ("k1", "k2", "c", "influence"):
            check_positive(getattr(self, name), name)
        check_positive(self.margin, "margin", strict=False)
        check_positive(self.band, "band")
        check_positive(self.variance_clearance, "variance_clearance", strict=False)
        if self.variance_clearance > self.band:
            raise InvalidInput(
                f"variance_clearance {self.variance_clearance} m must not exceed band "
                f"{self.band} m (the clearance above the margin)"
            )
        obstacles = tuple(self.obstacles)
        for i, ob in enumerate(obstacles):
            if not isinstance(ob, Box | Sphere):
                raise InvalidInput(f"obstacles[{i}] must be a Box or Sphere, got {type(ob)}")
        object.__setattr__(self, "obstacles", obstacles)
        if self.start_velocity not in _START_VELOCITY:
            raise InvalidInput(f"start_velocity must be one of {_START_VELOCITY}")
        if self.on_limit not in _ON_LIMIT:
            raise InvalidInput(f"on_limit must be one of {_ON_LIMIT}")
        if self.place_surface_z is not None:
            z = float(self.place_surface_z)
            if not np.isfinite(z) or z < 0.0:
                raise InvalidInput(
                    f"place_surface_z must be >= 0 m (the table is z = 0), got {z!r}"
                )
        check_positive(self.object_bottom, "object_bottom", strict=False)


def _resample(tb_model: FloatArray, values: FloatArray, tb: FloatArray) -> FloatArray:
    """Linear interpolation along axis 0 of (m, ...) values at normalised times."""
    flat = values.reshape(values.shape[0], -1)
    out = np.empty((tb.shape[0], flat.shape[1]))
    for j in range(flat.shape[1]):
        out[:, j] = np.interp(tb, tb_model, flat[:, j])
    return out.reshape((tb.shape[0], *values.shape[1:]))


def _pick_direction(
    ob: Obstacle, p: FloatArray, margin: float, influence: float
) -> tuple[str, FloatArray]:
    """Resolve ``auto``: the cheapest side that is not along the path's own motion."""
    if ob.direction != "auto":
        return ob.direction, direction_vector(ob.direction)
    best: tuple[float, str] | None = None
    tangent = np.gradient(p, axis=0)
    for name in ("+z", "+x", "-x", "+y", "-y"):
        n = direction_vector(name)
        _h, req = intrusion(ob, p, n, margin, influence)
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


def _blend_orientation_goal(
    q: FloatArray,
    omega: FloatArray,
    omegad: FloatArray,
    goal: FloatArray,
    S: FloatArray,
    Sd: FloatArray,
    Sdd: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Rotate the tail by ``exp(S(t) r / 2)`` so the last sample equals ``goal``.

    ``r`` [rad] is the small residual rotation from the DMP's end to the goal (base
    frame); ``S`` goes 0 -> 1 over the end of the motion with derivatives ``Sd``
    [1/s], ``Sdd`` [1/s²]. Angular velocity: ``omega' = Sd r + R_c omega``.
    """
    r = _rotvec_between(np.asarray(goal), q[-1])
    if not np.any(r):
        return q, omega, omegad
    qc = quat_exp(0.5 * S[:, None] * r[None, :])
    q_new = quat_sign_continuous(quat_multiply(qc, q))
    Rc = matrix_from_quat(qc)
    omega_new = Sd[:, None] * r[None, :] + np.einsum("nij,nj->ni", Rc, omega)
    omegad_new = (
        Sdd[:, None] * r[None, :]
        + np.einsum("nij,nj->ni", Rc, omegad)
        + np.cross(Sd[:, None] * r[None, :], np.einsum("nij,nj->ni", Rc, omega))
    )
    return q_new, omega_new, omegad_new


def check_model_covariance(model: LearnedModel) -> None:
    """Raise :class:`InvalidInput` unless every ``model.cov[k]`` is symmetric PSD.

    A GMR covariance is symmetric positive semi-definite by construction; anything
    else is a damaged or hand-edited file, and the variance term would read nonsense
    from it (a negative determinant). Tolerances are relative to the largest entry.
    """
    cov = np.asarray(model.cov, dtype=np.float64)
    scale = max(float(np.abs(cov).max()), 1e-300)
    asym = np.abs(cov - np.swapaxes(cov, -1, -2)).max(axis=(1, 2))
    bad = np.flatnonzero(asym > 1e-6 * scale)
    if bad.size:
        k = int(bad[0])
        raise InvalidInput(
            f"cov[{k}] (t = {model.t[k]:.3f} s) is not symmetric (|C - C^T| up to "
            f"{asym[k]:.3g}; {bad.size} of {cov.shape[0]} samples): not a covariance"
        )
    eig_min = np.linalg.eigvalsh(0.5 * (cov + np.swapaxes(cov, -1, -2)))[:, 0]
    bad = np.flatnonzero(eig_min < -1e-9 * scale)
    if bad.size:
        k = int(bad[0])
        raise InvalidInput(
            f"cov[{k}] (t = {model.t[k]:.3f} s) has a negative eigenvalue "
            f"{eig_min[k]:.3g} ({bad.size} of {cov.shape[0]} samples): a covariance "
            "must be positive semi-definite"
        )


def _check_above_table(
    x: FloatArray, nominal: FloatArray, obstacle_meta: list[dict[str, Any]]
) -> None:
    """Refuse a plan that goes below the table (z = 0), naming what pushed it there."""
    z_min = float(x[:, 2].min())
    if z_min >= TABLE_Z:
        return
    down = [i for i, ob in enumerate(obstacle_meta) if ob["direction_used"] == "-z"]
    if down and float(nominal[:, 2].min()) >= TABLE_Z:
        raise InvalidInput(
            f"obstacle {down[0]} pushes the plan {1e3 * (TABLE_Z - z_min):.0f} mm below "
            f"the table (z = {TABLE_Z} m): pass it along another direction (@+z, @auto)"
        )
    raise InvalidInput(
        f"the plan goes {1e3 * (TABLE_Z - z_min):.0f} mm below the table (z = {TABLE_Z} "
        "m); move the start/goal or the obstacles"
    )


def plan_from_model(model: LearnedModel, config: PlanConfig | None = None) -> Plan:
    """Plan an end-effector motion from a learned model.

    Parameters
    ----------
    model : LearnedModel
        GMR mean (position, quaternion, gripper) and covariance over time.
    config : PlanConfig, optional

    Returns
    -------
    Plan
        Sampled at ``config.rate_hz`` from 0 to the duration. ``meta`` holds the
        settings, obstacles (with the chosen direction, the coupling's Eq. 5.7
        ``gain``, the ``thesis_weight`` ``k2 nu``, ``displacement`` and
        ``required_lift`` [m] and ``min_clearance`` [m]) and the limit check;
        ``extras`` holds ``nominal_position`` (n, 3) (the path without obstacles),
        ``coupling_weight`` (n,) (the thesis weight ``k2 nu``), ``variance_level``
        (n,) (``nu``), and with obstacles ``clearance`` (n,) [m].

    Raises
    ------
    InvalidInput
        Bad configuration (named), start/goal outside the Panda's reach or inside an
        obstacle, an obstacle that cannot be cleared, or (``on_limit="raise"``) a
        plan beyond the Panda's Cartesian limits.
    """
    cfg = config or PlanConfig()
    if not isinstance(model, LearnedModel):
        raise InvalidInput(f"model must be a dexlfd.io.LearnedModel, got {type(model).__name__}")
    if model.n_samples < 4:
        raise InvalidInput(f"model has {model.n_samples} samples; a DMP needs at least 4")
    frame = str(model.meta.get("frame", "panda_base"))
    if frame.startswith("camera"):
        raise InvalidInput(
            f"model is in the {frame} frame, not the robot base frame: record the "
            "demonstrations with --extrinsics T.npy or --camera-pose (top-down/front)"
        )
    check_model_covariance(model)
    t_m = model.t
    mean = model.mean
    pos_m = mean[:, :3]
    quat_norm = np.linalg.norm(mean[:, 3:7], axis=1)
    if (quat_norm < 1e-6).any():
        raise InvalidInput("model.mean has zero-norm quaternions (columns 3:7)")
    if np.abs(quat_norm - 1).max() > 1e-3:
        logger.warning(
            "model mean quaternions deviate from unit norm by up to %.3g; renormalised",
            np.abs(quat_norm - 1).max(),
        )
    quat_m = quat_sign_continuous(mean[:, 3:7] / quat_norm[:, None])
    grip_m = mean[:, 7]

    x0 = np.asarray(cfg.start) if cfg.start is not None else pos_m[0].copy()
    g = np.asarray(cfg.goal) if cfg.goal is not None else pos_m[-1].copy()
    check_workspace(x0, "start")
    check_workspace(g, "goal")
    dcfg = cfg.dmp
    if np.linalg.norm(g - x0) < 1e-6:
        if dcfg.variant == "original":
            raise InvalidInput(
                "goal equals start: the original DMP (Eq. 5.1) degenerates to a point; "
                "use the modified DMP or a different goal"
            )
        logger.warning(
            "goal equals start %s: the modified DMP keeps the demonstrated shape and "
            "returns to the start",
            np.round(x0, 4).tolist(),
        )
    T = cfg.duration if cfg.duration is not None else float(t_m[-1] - t_m[0])
    n = max(2, int(round(T * cfg.rate_hz)) + 1)
    if n > MAX_SAMPLES:
        raise InvalidInput(
            f"duration {T:g} s at rate_hz {cfg.rate_hz:g} gives {n} samples; at most "
            f"{MAX_SAMPLES} (e.g. 1 h at 1 kHz) are planned at once"
        )
    tb = np.linspace(0.0, 1.0, n)
    tb_m = (t_m - t_m[0]) / (t_m[-1] - t_m[0])

    for i, ob in enumerate(cfg.obstacles):
        for name, point in (("start", x0), ("goal", g)):
            dist = float(signed_distance(ob, point)[0])
            if dist < 0:
                raise InvalidInput(
                    f"{name} {np.round(point, 4).tolist()} is inside obstacle {i} "
                    f"({ob.to_dict()}); move the {name} or the obstacle"
                )
            if dist < cfg.margin:
                logger.warning(
                    "%s is %.3f m from obstacle %d, closer than the margin %.3f m",
                    name,
                    dist,
                    i,
                    cfg.margin,
                )

    # position: modified (or original) DMP, Eq. (5.5) / (5.1)
    dmp = fit_dmp(*_fit_grid(t_m, pos_m), dcfg)
    v0 = dmp.v0 if cfg.start_velocity == "model" else np.zeros(3)
    x, xd, xdd = _rollout_impl(dmp, tb, x0, g, v0, None, None)
    nominal = x.copy()

    cov_p = _resample(tb_m, model.cov[:, :3, :3], tb)
    nu = variance_level(cov_p) if cfg.variance_aware else np.zeros(n)
    w = cfg.k2 * nu if cfg.variance_aware else np.ones(n)
    obstacle_meta: list[dict[str, Any]] = []
    win, dwin, ddwin = _taper(tb)
    lead = _LEAD / np.sqrt(dcfg.K_bar)
    n_lead = int(round(lead * (n - 1)))
    # avoiding must not make the motion faster than the demonstrated one
    nominal_speed = float(np.linalg.norm(xd, axis=1).max())
    for i, ob in enumerate(cfg.obstacles):
        name, nvec = _pick_direction(ob, nominal, cfg.margin, cfg.influence)
        h, req = intrusion(ob, nominal, nvec, cfg.margin, cfg.influence)
        info: dict[str, Any] = {
            **ob.to_dict(),
            "direction_used": name,
            "max_intrusion": float(h.max()),
            "required_lift": float(req.max()),
            "coupling": "shaped" if cfg.enforce_clearance else "thesis",
        }
        over = req > 0
        if over.any():
            info["variance_level"] = float(nu[over].max())
            info["thesis_weight"] = float(w[over].max())
        if cfg.enforce_clearance and over.any():
            sc = shape_coupling(
                dcfg, tb, req, nu, (win, dwin, ddwin),
                kappa=cfg.variance_clearance, band=cfg.band, lead=lead,
                c=cfg.c, k1=cfg.k1, h_peak=float(h.max()),
                velocity=xd @ nvec, speed_cap=nominal_speed,
            )  # fmt: skip
            if not sc.band_met:
                logger.warning(
                    "obstacle %d: the path cannot pass within margin + band (%.3f m); "
                    "it clears by more",
                    i,
                    cfg.margin + cfg.band,
                )
            x = x + sc.x[:, None] * nvec[None, :]
            xd = xd + sc.xd[:, None] * nvec[None, :]
            xdd = xdd + sc.xdd[:, None] * nvec[None, :]
            info["gain"] = sc.gain
            info["displacement"] = float(sc.x.max())
            logger.info(
                "obstacle %d: shaped coupling, gain %.3g (thesis weight %.3g), "
                "displacement %.3f m for a needed lift of %.3f m",
                i, sc.gain, info["thesis_weight"], sc.x.max(), req.max(),
            )  # fmt: skip
        elif h.max() > 0:
            # Eqs. (5.6)-(5.7) as printed: u = c k2 nu k1 h. The variance is the one
            # where the path meets the obstacle; the lead starts the push earlier.
            u = (cfg.c * _lead(w * cfg.k1 * h, n_lead))[:, None] * nvec[None, :]
            rx0, rxd0, rxdd0 = coupling_response(dcfg, n, u)
            # fade the displacement out at the end so the goal is still reached
            x = x + rx0 * win[:, None]
            xd = xd + rxd0 * win[:, None] + rx0 * dwin[:, None]
            xdd = xdd + rxdd0 * win[:, None] + 2 * rxd0 * dwin[:, None] + rx0 * ddwin[:, None]
            info["gain"] = float(w[h > 0].max())
            info["displacement"] = float((rx0 * win[:, None] @ nvec).max())
        obstacle_meta.append(info)

    # The modified DMP reaches g only as t -> inf: at t = T the fading phase terms and
    # the fit leave a residual (0.26 % of the goal change, more for a noisy mean).
    # Blend it out over the last 10 % so the plan ends exactly at the goal.
    residual = x[-1] - g
    end_err = float(np.linalg.norm(residual))
    if end_err > _GOAL_WARN:
        logger.warning(
            "the DMP ends %.2f mm from the goal (noisy or coarse model?); blended out over "
            "the last %d %% of the motion",
            1e3 * end_err,
            int(100 * _TAPER),
        )
    x = x - residual[None, :] * (1.0 - win)[:, None]
    xd = xd + residual[None, :] * dwin[:, None]
    xdd = xdd + residual[None, :] * ddwin[:, None]
    # The learned mean may still move at its last sample (a demonstration cut off
    # mid-motion), and the DMP passes that velocity on: bring the plan to rest at
    # the goal over the same window, so the robot is not stopped dead.
    end_speed = float(np.linalg.norm(xd[-1])) / T
    dx, dxd, dxdd = _rest_correction(tb, xd[-1], xdd[-1])
    x, xd, xdd = x + dx, xd + dxd, xdd + dxdd

    gripper = np.interp(tb, tb_m, grip_m)  # learned schedule in phase
    if gripper.min() < 0.0 or gripper.max() > GRIPPER_OPENING_MAX:
        logger.info(
            "gripper schedule %.3f..%.3f m clipped to the hand's range 0..%.2f m",
            gripper.min(), gripper.max(), GRIPPER_OPENING_MAX,
        )  # fmt: skip
        gripper = np.clip(gripper, 0.0, GRIPPER_OPENING_MAX)
    place_meta: dict[str, Any] | None = None
    if cfg.place_surface_z is not None:
        pc = place_correction(
            tb * T, x, xd / T, xdd / T**2, gripper,
            surface_z=cfg.place_surface_z, object_bottom=cfg.object_bottom,
        )  # fmt: skip
        x = x + pc.dz
        xd = xd + pc.dzd * T
        xdd = xdd + pc.dzdd * T**2
        k_r = int(np.searchsorted(tb * T, pc.release_t))
        place_meta = {
            "surface_z": cfg.place_surface_z,
            "object_bottom": cfg.object_bottom,
            "release_t": pc.release_t,
            "place_point": x[k_r].tolist(),
            "height_change": pc.shift,
        }
        if cfg.place_surface_z > TABLE_Z:
            # what the object is set down on: a support from the table up to the
            # surface under the place point (the simulator builds it from here)
            px, py = x[k_r, 0], x[k_r, 1]
            height = cfg.place_surface_z - TABLE_Z
            place_meta["support"] = {
                "type": "box",
                "center": [float(px), float(py), TABLE_Z + height / 2],
                "size": [_SUPPORT_WIDTH, _SUPPORT_WIDTH, height],
            }
        logger.info(
            "place: object lowered %.3f m onto the surface at z = %.3f m before the "
            "release at t = %.2f s",
            -pc.shift, cfg.place_surface_z, pc.release_t,
        )  # fmt: skip
    _check_above_table(x, nominal, obstacle_meta)

    clearance = None
    if cfg.obstacles:
        per = np.stack([signed_distance(ob, x) for ob in cfg.obstacles])
        clearance = per.min(axis=0)
        for i, info in enumerate(obstacle_meta):
            info["min_clearance"] = float(per[i].min())
            if per[i].min() < cfg.margin - 1e-6:
                msg = (
                    f"the plan passes {per[i].min():.3f} m from obstacle {i} "
                    f"({cfg.obstacles[i].to_dict()}), less than the margin {cfg.margin} m"
                )
                if per[i].min() < 0 and cfg.enforce_clearance:
                    raise InvalidInput(msg + "; it collides")
                logger.warning("%s", msg)

    # orientation: quaternion DMP
    t_q, quat_fit = _fit_grid(t_m, quat_m)
    qdmp = fit_quaternion_dmp(t_q, quat_fit / np.linalg.norm(quat_fit, axis=1)[:, None], dcfg)
    if cfg.start_velocity == "zero":
        qdmp = dataclasses.replace(qdmp, eta0=np.zeros(3))
    q0 = np.asarray(cfg.start_quat) if cfg.start_quat is not None else quat_m[0]
    qg = np.asarray(cfg.goal_quat) if cfg.goal_quat is not None else quat_m[-1]
    qr = rollout_quaternion_dmp(qdmp, q0=q0, g=qg, duration=T, n_steps=n)
    quaternion, omega, omegad = _blend_orientation_goal(
        qr.q, qr.omega, qr.omegad, qg, 1.0 - win, -dwin / T, -ddwin / T**2
    )
    t = tb * T
    velocity = xd / T
    acceleration = xdd / T**2
    report = check_cartesian_limits(velocity, acceleration, omega, omegad)
    for msg in report.exceeded:
        if cfg.on_limit == "raise":
            raise InvalidInput(f"duration {T:g} s: {msg}")
        logger.warning("duration %g s: %s", T, msg)

    settings = dataclasses.asdict(cfg)
    settings["obstacles"] = [ob.to_dict() for ob in cfg.obstacles]
    meta = {
        "frame": "panda_base",
        "units": {
            "t": "s",
            "position": "m",
            "velocity": "m/s",
            "acceleration": "m/s^2",
            "angular_velocity": "rad/s",
            "gripper": "m",
        },
        "settings": settings,
        "start": x0.tolist(),
        "goal": g.tolist(),
        "duration": T,
        "goal_error": float(np.linalg.norm(x[-1] - g)),
        "dmp_goal_residual": end_err,
        "dmp_end_speed": end_speed,
        "obstacles": obstacle_meta,
        "place": place_meta,
        "limits": {"peaks": report.peaks, "exceeded": list(report.exceeded)},
        "model_meta": {k: v for k, v in model.meta.items() if k in ("source", "software")},
        "method": "modified DMP (Pastor 2009) + quaternion DMP (Ude 2014) + "
        "variance-aware Gams coupling (thesis Eq. 5.7)",
    }
    extras: dict[str, np.ndarray] = {
        "nominal_position": nominal,
        "coupling_weight": w,
        "variance_level": nu,
    }
    if clearance is not None:
        extras["clearance"] = clearance
    logger.info(
        "plan: %d samples over %.2f s, goal error %.2f mm, %d obstacle(s)",
        n,
        T,
        1e3 * end_err,
        len(cfg.obstacles),
    )
    return Plan(
        t=t,
        position=x,
        velocity=velocity,
        acceleration=acceleration,
        quaternion=quaternion,
        angular_velocity=omega,
        gripper=gripper,
        meta=meta,
        extras=extras,
    )
