"""Monte-Carlo version of the payload study: random plants, means and 95 % intervals.

Table 5.1 (:mod:`dexlfd.experiments.payload`) compares the controllers on one
plant. Here every trial draws a plant at random - the unknown object's mass,
the controller model's mass/inertia error, the measurement noise level, the
torque delay and the seeds of the model error and the noise - and runs the
Table 5.1 comparison on it (every controller with and without the object, so
``ΔE = E_OB − E_NOB`` is paired within the trial). All controllers see the same
plant in a trial (common random numbers), so their differences are not noise
of the draw.

A trial's randomness comes only from :func:`~dexlfd.engine.item_seed`
of the study seed and the trial's index, so the numbers are the same on any
engine and any number of workers. Trials run through
:func:`~dexlfd.engine.map_items`; a trial that fails is reported
and left out, the others are summarised.

Per controller the summary gives the mean of each metric and its two-sided
Student-t confidence interval, ``mean ± t_{(1+level)/2, n-1} s / √n``.
``ΔE/kg`` (ΔE over the object's mass) has a closed form for the Cartesian PD:
``g / K_p`` (16.35 mm/kg at K_p = 600 N/m).

References
----------
.. [1] Thesis §5.3.3, Eqs. (5.27)–(5.28), Table 5.1.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd.engine import ItemOutcome, item_seed, map_items
from dexlfd.errors import InvalidInput
from dexlfd.experiments.payload import PayloadConfig, PayloadRow, run_payload_experiment
from dexlfd.panda import MAX_PAYLOAD

__all__ = [
    "METRICS",
    "ControllerSummary",
    "Interval",
    "MonteCarloConfig",
    "MonteCarloResult",
    "TrialDraw",
    "TrialResult",
    "draw_trial",
    "format_monte_carlo",
    "mean_interval",
    "monte_carlo_json",
    "run_payload_monte_carlo",
    "run_trial",
]

logger = logging.getLogger(__name__)

# summarised metrics: name -> (label, unit shown, factor from SI)
METRICS: dict[str, tuple[str, str, float]] = {
    "e_nob_m": ("E_NOB", "mm", 1e3),
    "e_ob_m": ("E_OB", "mm", 1e3),
    "delta_e_m": ("ΔE", "mm", 1e3),
    "delta_e_per_kg_m": ("ΔE/kg", "mm/kg", 1e3),
    "sag_m": ("sag", "mm", 1e3),
    "max_abs_z_error_m": ("max|e_z|", "mm", 1e3),
    "max_orientation_error_rad": ("rot max", "deg", 180.0 / math.pi),
}


def _check_range(name: str, lo_hi: tuple[float, float], low: float, high: float) -> None:
    lo, hi = lo_hi
    if not (np.isfinite(lo) and np.isfinite(hi) and low <= lo <= hi <= high):
        raise InvalidInput(
            f"MonteCarloConfig.{name} must be a range lo <= hi within [{low}, {high}], got {lo_hi}"
        )


@dataclass(frozen=True, slots=True)
class MonteCarloConfig:
    """Settings of the Monte-Carlo payload study.

    Attributes
    ----------
    trials : int
        Number of random plants, >= 1.
    base : PayloadConfig
        Everything a trial does not draw: controllers, plan or lift duration,
        friction, contacts, metrics window; and where the trials run
        (``engine``, ``workers``, ``ray_address``). Its ``payloads``,
        ``model_error``, noise, delay and ``seed`` are replaced per trial.
    payload_kg : (float, float)
        Object mass drawn uniformly from this range [kg], within [0, 3].
    model_error : (float, float)
        Relative mass/inertia error of the controller's model, uniform [-], in [0, 1).
    noise_scale : (float, float)
        Factor on ``base.q_noise`` [rad] and ``base.dq_noise`` [rad/s], uniform [-].
    torque_delay : (int, int)
        Torque delay drawn uniformly from these ticks (both included).
    seed : int
        Study seed; trial ``i`` uses ``item_seed(seed, i)`` only.
    level : float
        Confidence level of the intervals, in (0, 1).
    """

    trials: int = 32
    base: PayloadConfig = field(default_factory=PayloadConfig)
    payload_kg: tuple[float, float] = (0.2, 1.5)
    model_error: tuple[float, float] = (0.0, 0.2)
    noise_scale: tuple[float, float] = (0.0, 2.0)
    torque_delay: tuple[int, int] = (0, 2)
    seed: int = 0
    level: float = 0.95

    def __post_init__(self) -> None:
        if isinstance(self.trials, bool) or not isinstance(self.trials, int) or self.trials < 1:
            raise InvalidInput(f"trials must be an integer >= 1, got {self.trials!r}")
        _check_range("payload_kg", self.payload_kg, 0.0, MAX_PAYLOAD)
        _check_range("model_error", self.model_error, 0.0, 0.99)
        _check_range("noise_scale", self.noise_scale, 0.0, math.inf)
        lo, hi = self.torque_delay
        if not (isinstance(lo, int) and isinstance(hi, int) and 0 <= lo <= hi):
            raise InvalidInput(
                "MonteCarloConfig.torque_delay must be ticks 0 <= lo <= hi, "
                f"got {self.torque_delay}"
            )
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InvalidInput(f"seed must be an integer >= 0, got {self.seed!r}")
        if not 0.0 < self.level < 1.0:
            raise InvalidInput(f"level must be in (0, 1), got {self.level!r}")


@dataclass(frozen=True, slots=True)
class TrialDraw:
    """The random plant of one trial (SI units)."""

    index: int
    payload_kg: float
    model_error: float
    noise_scale: float
    torque_delay: int
    sim_seed: int  # seeds the model error and the noise of every run of the trial


@dataclass(frozen=True, slots=True)
class TrialResult:
    """One trial: its plant and the Table 5.1 row of each controller."""

    draw: TrialDraw
    rows: tuple[PayloadRow, ...]


@dataclass(frozen=True, slots=True)
class Interval:
    """A mean and its confidence interval (NaN bounds when n < 2)."""

    mean: float
    low: float
    high: float
    n: int


@dataclass(frozen=True, slots=True)
class ControllerSummary:
    """One controller over the trials it finished carrying the object in."""

    controller: str
    n_trials: int
    n_excluded: int  # safety stop or object not carried
    stats: dict[str, Interval]


@dataclass(frozen=True, slots=True)
class MonteCarloResult:
    """The trials, the failed ones and the per-controller summary."""

    config: MonteCarloConfig
    trials: list[TrialResult]
    summary: list[ControllerSummary]
    failures: list[ItemOutcome] = field(default_factory=list)
    outcomes: list[ItemOutcome] = field(default_factory=list)  # per-trial timings


def draw_trial(cfg: MonteCarloConfig, index: int) -> TrialDraw:
    """The plant of trial ``index``: a function of ``cfg.seed`` and ``index`` only."""
    rng = np.random.default_rng(item_seed(cfg.seed, index))
    return TrialDraw(
        index=int(index),
        payload_kg=float(rng.uniform(*cfg.payload_kg)),
        model_error=float(rng.uniform(*cfg.model_error)),
        noise_scale=float(rng.uniform(*cfg.noise_scale)),
        torque_delay=int(rng.integers(cfg.torque_delay[0], cfg.torque_delay[1] + 1)),
        sim_seed=int(rng.integers(0, 2**63 - 1)),
    )


def trial_config(cfg: MonteCarloConfig, draw: TrialDraw) -> PayloadConfig:
    """The Table 5.1 settings of one trial (run in-process, no object and ``draw``'s)."""
    b = cfg.base
    return dataclasses.replace(
        b,
        payloads=(0.0, draw.payload_kg),
        model_error=draw.model_error,
        q_noise=b.q_noise * draw.noise_scale,
        dq_noise=b.dq_noise * draw.noise_scale,
        torque_delay=draw.torque_delay,
        seed=draw.sim_seed,
        workers=1,
        engine="local",
        ray_address=None,
    )


def run_trial(cfg: MonteCarloConfig, index: int) -> TrialResult:
    """Draw trial ``index``'s plant and run every controller on it with and without the object."""
    draw = draw_trial(cfg, index)
    result = run_payload_experiment(trial_config(cfg, draw))
    return TrialResult(draw=draw, rows=tuple(result.rows))


def mean_interval(x: Any, level: float = 0.95) -> Interval:
    """Mean of the finite values of ``x`` and its Student-t interval at ``level``."""
    from scipy import stats

    v = np.asarray(x, dtype=float)
    v = v[np.isfinite(v)]
    n = int(v.size)
    if n == 0:
        return Interval(math.nan, math.nan, math.nan, 0)
    mean = float(v.mean())
    if n < 2:
        return Interval(mean, math.nan, math.nan, n)
    half = float(stats.t.ppf(0.5 + level / 2, n - 1) * v.std(ddof=1) / math.sqrt(n))
    return Interval(mean, mean - half, mean + half, n)


def _metric(row: PayloadRow, name: str) -> float:
    if name == "delta_e_per_kg_m":
        return row.delta_e_m / row.payload_kg if row.payload_kg > 0 else math.nan
    return float(getattr(row, name))


def _summarise(cfg: MonteCarloConfig, trials: list[TrialResult]) -> list[ControllerSummary]:
    out = []
    for c in cfg.base.controllers:
        rows = [r for t in trials for r in t.rows if r.controller == c]
        kept = [r for r in rows if r.stopped is None and np.isfinite(r.e_ob_m)]
        stats = {m: mean_interval([_metric(r, m) for r in kept], cfg.level) for m in METRICS}
        out.append(ControllerSummary(c, len(kept), len(rows) - len(kept), stats))
    return out


def run_payload_monte_carlo(
    cfg: MonteCarloConfig,
    *,
    quiet: bool = True,
    callback: Callable[[int, float], None] | None = None,
) -> MonteCarloResult:
    """Run ``cfg.trials`` random plants on ``cfg.base.engine`` and summarise them.

    ``callback(i, seconds)`` is called after each finished trial; ``quiet=False``
    shows a progress bar.
    """
    b = cfg.base
    outcomes = map_items(
        functools.partial(run_trial, cfg), list(range(cfg.trials)),
        labels=[f"trial {i}" for i in range(cfg.trials)],
        engine=b.engine, workers=b.workers, address=b.ray_address,
        desc="payload Monte-Carlo", quiet=quiet, callback=callback,
    )  # fmt: skip
    trials = [o.value for o in outcomes if o.ok]
    failures = [o for o in outcomes if not o.ok]
    summary = _summarise(cfg, trials)
    for s in summary:
        e = s.stats["delta_e_m"]
        logger.info("%-12s n=%d  ΔE %.3f mm [%.3f, %.3f]", s.controller, s.n_trials,
                    1e3 * e.mean, 1e3 * e.low, 1e3 * e.high)  # fmt: skip
    return MonteCarloResult(cfg, trials, summary, failures, outcomes)


def format_monte_carlo(result: MonteCarloResult) -> str:
    """Plain-text table: per controller, each metric's mean [low, high]."""
    cfg = result.config
    b = cfg.base
    n_ok = len(result.trials)
    lines = [
        f"Payload Monte-Carlo: {n_ok} of {cfg.trials} trials, seed {cfg.seed}; mean "
        f"[{100 * cfg.level:g} % t-interval] per controller",
        f"draws per trial: object {cfg.payload_kg[0]:g}-{cfg.payload_kg[1]:g} kg, model "
        f"error {100 * cfg.model_error[0]:g}-{100 * cfg.model_error[1]:g} %, noise x"
        f"{cfg.noise_scale[0]:g}-{cfg.noise_scale[1]:g} of (q {b.q_noise:g} rad, dq "
        f"{b.dq_noise:g} rad/s), torque delay {cfg.torque_delay[0]}-{cfg.torque_delay[1]} "
        f"tick(s); "
        + (f"{b.duration:g} s stand-in lift" if b.plan is None else "the given plan")
        + f", friction x{b.friction_scale:g}, contacts {'on' if b.contacts else 'off'}",
        "",
    ]
    width = 24
    head = f"{'controller':<12} {'n':>3} {'excl':>4}" + "".join(
        f" {f'{label} [{unit}]':>{width}}" for label, unit, _ in METRICS.values()
    )
    lines.append(head)
    for s in result.summary:
        cells = []
        for name, (_, _, k) in METRICS.items():
            iv = s.stats[name]
            cells.append(f" {f'{k * iv.mean:.3f} [{k * iv.low:.3f}, {k * iv.high:.3f}]':>{width}}")
        lines.append(f"{s.controller:<12} {s.n_trials:>3} {s.n_excluded:>4}" + "".join(cells))
    from dexlfd.control import make_controller

    kp = make_controller("pd").describe()["K_p"]
    lines.append(f"closed form for PD: ΔE/kg = g / K_p = {1e3 * 9.81 / kp:.2f} mm/kg")
    lines.append("excl: trials with a safety stop or the object not carried (left out)")
    for o in result.failures:
        lines.append(f"FAILED {o.label}: {o.error}")
    return "\n".join(lines)


def _finite(v: Any) -> Any:
    # NaN is not valid JSON (RFC 8259): write null
    return None if isinstance(v, float) and not math.isfinite(v) else v


def monte_carlo_json(result: MonteCarloResult) -> dict[str, Any]:
    """The study as a JSON-able dict: settings, summary, every trial, failures."""
    cfg = result.config
    b = cfg.base
    return {
        "kind": "payload_monte_carlo",
        "trials_requested": cfg.trials,
        "seed": cfg.seed,
        "level": cfg.level,
        "draws": {
            "payload_kg": list(cfg.payload_kg),
            "model_error": list(cfg.model_error),
            "noise_scale": list(cfg.noise_scale),
            "torque_delay_ticks": list(cfg.torque_delay),
        },
        "controllers": list(b.controllers),
        "summary": [
            {
                "controller": s.controller,
                "n_trials": s.n_trials,
                "n_excluded": s.n_excluded,
                **{
                    m: {"mean": _finite(iv.mean), "low": _finite(iv.low), "high": _finite(iv.high)}
                    for m, iv in s.stats.items()
                },
            }
            for s in result.summary
        ],
        "trials": [
            {
                **dataclasses.asdict(t.draw),
                "rows": [{k: _finite(v) for k, v in r.json_row().items()} for r in t.rows],
            }
            for t in result.trials
        ],
        "failures": [
            {"index": o.index, "label": o.label, "error": o.error} for o in result.failures
        ],  # fmt: skip
    }
