"""Table 5.1 in simulation: tracking a lift with an unknown payload, then beating it.

Each controller tracks the same lift plan (:func:`~dexlfd.plan.moves.lift_plan`)
with no object, 0.45 kg and 1.2 kg that its model does not contain. The plant is
realistic by default (see :class:`PayloadConfig`): Gaz et al. (2019) joint
friction, a 10 % mass/inertia error in the controller's model, measurement
noise, a one-tick torque delay, contacts; the object waits on a pedestal and is
grasped by the fingers (70 N, friction) at t = 0, the instant the lift starts
(no settling time).

Metrics (z axis, Eqs. 5.27–5.28) are taken while the object is carried over the
obstacle: the samples where the reference is at least ``clearance`` above the
pick height (the thesis analyses "the motion of the object over the
obstacle"). ``ΔE = E_OB − E_NOB`` is the primary figure: with a near-perfect
simulated no-load run, the relative Δ_OB is dominated by the tiny denominator.
``sag`` is the mean z difference between the loaded and unloaded runs, which
for a Cartesian PD is the closed form weight / K_p.

References
----------
.. [1] Thesis §5.3.3, Eqs. (5.27)–(5.28), Table 5.1, Fig. 5.9.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from dexlfd.control import LoopConfig, TrackingStopped, make_controller, track
from dexlfd.control.slip import carry_slip
from dexlfd.engine import ENGINES, format_failures, map_items
from dexlfd.errors import DexlfdError, InvalidInput
from dexlfd.geometry import Box, Obstacle
from dexlfd.io import Plan, Rollout
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import PlantConfig, perturbed_model
from dexlfd.robot.plant import HALF_SIZES

__all__ = [
    "MAX_SIMULATED_S",
    "SIM_SPEED_X",
    "THESIS_TABLE",
    "PayloadConfig",
    "check_workload",
    "PayloadResult",
    "PayloadRow",
    "format_table",
    "lift_metrics",
    "run_payload_rollout",
    "run_payload_experiment",
]

logger = logging.getLogger(__name__)

# [s] of robot time one study simulates at 1 kHz: ~9 h of one core at the ~30x real time of
# the simulation (measured), minutes on a Ray cluster; 5000 Monte-Carlo trials of the
# default study (6 s, 5 controllers: 300,000 s) fit, 100,000 trials of a 60 s lift do not
MAX_SIMULATED_S = 1_000_000.0
SIM_SPEED_X = 30.0  # robot time simulated per second of one core (measured, ~30x)

# Thesis Table 5.1 (real Panda): (controller, payload kg) -> E_NOB [m], E_OB [m], Δ_OB [%]
THESIS_TABLE: dict[tuple[str, float], tuple[float, float, float]] = {
    ("pd", 0.45): (0.01267, 0.02453, 93.61),
    ("sm-pd", 0.45): (0.01626, 0.02245, 37.45),
    ("ntsm-pd", 0.45): (0.01538, 0.01877, 22.04),
    ("pd", 1.2): (0.01267, 0.03210, 153.35),
    ("sm-pd", 1.2): (0.01626, 0.02448, 50.55),
    ("ntsm-pd", 1.2): (0.01538, 0.01738, 13.00),
}


# the thesis's own laws (Table 5.1's rows and the joint-space SM of Eqs. 5.21-5.22): never "ours"
THESIS_LAWS = ("pd", "sm-pd", "ntsm-pd", "sm-joint")

# obstacle under the top of the lift (shown in videos; the carried object clears it)
LIFT_OBSTACLE = Box(center=(0.45, 0.0, 0.175), size=(0.12, 0.08, 0.35))


@dataclass(frozen=True, slots=True)
class PayloadConfig:
    """Settings of the payload study; defaults are the documented realistic plant.

    Attributes
    ----------
    controllers : tuple of str
        Registry names (:data:`dexlfd.control.CONTROLLERS`).
    payloads : tuple of float
        Object masses [kg]; must include 0 (the no-object baseline).
    duration : float
        Lift time [s].
    model_error : float
        Relative mass/inertia error of the controller's model [-].
    friction_scale : float
        Factor on Gaz et al.'s friction [-].
    q_noise, dq_noise : float
        Measurement noise std [rad], [rad/s].
    torque_delay : int
        Ticks of torque delay.
    contacts : bool
        Simulate contacts.
    clearance : float
        Metrics window: reference z at least this far above the pick height [m].
    seed : int
        Seeds the model error (same for every run) and the noise (same sequence
        for every run).
    workers : int
        Processes, or CPUs of a local Ray cluster (1 = sequential).
    engine : {"local", "ray"}
        Where the runs go (:func:`~dexlfd.engine.map_items`).
    ray_address : str, optional
        A running Ray cluster for ``engine="ray"`` (default: start a local one).
    plan : Plan, optional
        The trajectory to track (e.g. a variance-avoidance DMP plan that picks
        the object, carries it over the obstacle and places it); default: the
        stand-in :func:`~dexlfd.plan.moves.lift_plan` of ``duration``.
    obstacles : tuple of Obstacle, optional
        Obstacles of the plant; default: :data:`LIFT_OBSTACLE` for the stand-in
        lift, none for a given plan.
    hand : {"franka", "softhand"}
        The end-effector (:class:`~dexlfd.robot.PlantConfig`; the softhand squeezes
        with ``stop_force``).
    shape : {"box", "cylinder", "sphere"}
        The object, of its default size (:data:`dexlfd.robot.plant.HALF_SIZES`).
    stop_force : float
        The softhand's grasp force [N] (the thesis's 3 N).
    """

    controllers: tuple[str, ...] = ("pd", "sm-pd", "ntsm-pd", "ntsm-pd-i", "ntsm-pd-dob")
    payloads: tuple[float, ...] = (0.0, 0.45, 1.2)
    duration: float = 6.0
    model_error: float = 0.1
    friction_scale: float = 1.0
    q_noise: float = 1e-5
    dq_noise: float = 1e-3
    torque_delay: int = 1
    contacts: bool = True
    clearance: float = 0.05
    seed: int = 0
    workers: int = 1
    plan: Plan | None = None
    obstacles: tuple[Obstacle, ...] | None = None
    engine: str = "local"
    ray_address: str | None = None
    hand: str = "franka"
    shape: str = "box"
    stop_force: float = 3.0

    def __post_init__(self) -> None:
        self.plant(max(self.payloads, default=0.0))  # hand, shape, and can the hand hold it
        if 0.0 not in self.payloads:
            raise InvalidInput(f"payloads must include 0.0 (no object), got {self.payloads}")
        if not self.controllers:
            raise InvalidInput("controllers must not be empty")
        if self.workers < 1:
            raise InvalidInput(f"workers must be >= 1, got {self.workers}")
        if self.engine not in ENGINES:
            raise InvalidInput(f"engine must be one of {ENGINES}, got {self.engine!r}")
        for name in self.controllers:
            make_controller(name)  # raises on unknown names

    def plant(self, payload_kg: float) -> PlantConfig:
        """The plant of one run."""
        return PlantConfig(
            payload_kg=payload_kg,
            friction_scale=self.friction_scale,
            contacts=self.contacts,
            obstacles=self.plant_obstacles(),
            hand=self.hand,
            stop_force=self.stop_force,
            payload_shape=self.shape,
            payload_half_size=HALF_SIZES[self.shape],
        )

    def plant_obstacles(self) -> tuple[Obstacle, ...]:
        """The obstacles of every run."""
        if self.obstacles is not None:
            return self.obstacles
        return () if self.plan is not None else (LIFT_OBSTACLE,)

    def tracked_plan(self) -> Plan:
        """The plan every run tracks."""
        return self.plan if self.plan is not None else lift_plan(self.duration)

    def loop(self) -> LoopConfig:
        """The loop settings of every run."""
        return LoopConfig(
            q_noise=self.q_noise, dq_noise=self.dq_noise, torque_delay=self.torque_delay
        )


@dataclass(frozen=True, slots=True)
class PayloadRow:
    """One controller at one payload (SI units: m, rad, N·m/s)."""

    controller: str
    payload_kg: float
    e_nob_m: float
    e_ob_m: float
    delta_ob_pct: float
    delta_e_m: float
    sag_m: float
    max_abs_z_error_m: float
    rms_orientation_error_rad: float
    max_orientation_error_rad: float
    max_torque_rate_nm_per_s: float
    stopped: str | None = None
    slip_m: float | None = None  # the object's largest slide in the hand while carried

    def json_row(self) -> dict[str, Any]:
        """The ``--json`` record (contract fields first)."""
        d = asdict(self)
        return {
            "controller": d.pop("controller"),
            "payload_kg": d.pop("payload_kg"),
            "e_nob_m": d.pop("e_nob_m"),
            "e_ob_m": d.pop("e_ob_m"),
            "delta_ob_pct": d.pop("delta_ob_pct"),
            **d,
        }


@dataclass(frozen=True, slots=True)
class PayloadResult:
    """Rows for every (controller, payload > 0), the rollouts and the settings."""

    rows: list[PayloadRow]
    rollouts: dict[tuple[str, float], Rollout]
    config: PayloadConfig
    best: str | None = None
    notes: list[str] = field(default_factory=list)


def lift_metrics(rollout: Rollout, clearance: float) -> dict[str, Any]:
    """Z RMSE (Eq. 5.27) etc. over the carried part of a rollout.

    Returns ``e_z`` (RMSE [m]), ``z_err`` (the error series in the window [m]),
    ``mask`` (n,), orientation error RMS/max [rad], max torque rate [N·m/s].
    """
    z_ref = rollout.ref_position[:, 2]
    # the carried part: the grasp schedule is closed and the reference is at least
    # `clearance` above where the grasp began (for a lift plan: its start); a rollout
    # without a schedule (an old file) counts as held throughout
    closed = np.ones(z_ref.shape, bool) if rollout.grasp is None else np.asarray(rollout.grasp)
    k_grasp = int(np.argmax(closed)) if closed.any() else 0
    mask = closed & (z_ref >= z_ref[k_grasp] + clearance)
    if not mask.any():
        raise InvalidInput(
            f"the reference never rises {clearance} m above the grasp point with the gripper closed"
        )
    ez = rollout.ee_position[:, 2] - z_ref
    e_rot = rollout.extras.get("orientation_error", np.zeros_like(ez))
    dt = np.diff(rollout.t)
    rate = np.abs(np.diff(rollout.tau, axis=0)) / dt[:, None] if dt.size else np.zeros((1, 7))
    return {
        "e_z": float(np.sqrt(np.mean(ez[mask] ** 2))),  # [1] Eq. (5.27)
        "z_err": ez,
        "mask": mask,
        "max_abs_z": float(np.abs(ez[mask]).max()),
        "rot_rms": float(np.sqrt(np.mean(e_rot[mask] ** 2))),
        "rot_max": float(np.max(e_rot[mask])),
        "torque_rate_max": float(rate.max()),
    }


def _run_one(cfg: PayloadConfig, job: tuple[str, float]) -> tuple[str, float, Rollout]:
    name, payload = job
    model = perturbed_model(cfg.model_error, np.random.default_rng([cfg.seed, 1]))
    plan = cfg.tracked_plan()
    try:
        ro = track(
            plan, make_controller(name), model, cfg.plant(payload), cfg.loop(),
            rng=np.random.default_rng([cfg.seed, 2]),
        )  # fmt: skip
    except TrackingStopped as exc:
        ro = exc.rollout
    return name, payload, ro


def _not_carried(rollout: Rollout) -> str | None:
    """Why the object was not carried through the run, or None if it was."""
    events = rollout.grasp_events
    if events:
        return f"NOT CARRIED: grasp {events[0].event} at t={events[0].t:.2f} s"
    if not np.asarray(rollout.extras.get("attached", [False])).any():
        return "NOT CARRIED: the object was never in the hand"
    return None


def check_workload(cfg: PayloadConfig, trials: int = 0) -> float:
    """Robot time [s] the study simulates; :class:`InvalidInput` beyond MAX_SIMULATED_S.

    The table runs every controller with every payload; ``trials`` > 0 random plants
    run every controller with and without the object. Checked before any run.
    """
    plan = cfg.tracked_plan()
    span = float(plan.t[-1] - plan.t[0])
    runs = len(cfg.controllers) * (2 * trials if trials else len(cfg.payloads))
    total = runs * span
    if total > MAX_SIMULATED_S:
        fewer = "trials" if trials else "payloads"
        raise InvalidInput(
            f"the study simulates {runs} runs of {span:.3g} s, {total:.3g} s of robot time; "
            f"at most {MAX_SIMULATED_S:,.0f} s: fewer {fewer} or controllers, "
            "or a shorter duration",
            param=fewer,
        )
    return total


def run_payload_rollout(cfg: PayloadConfig, controller: str, payload_kg: float) -> Rollout:
    """One run of the study, in this process: what :func:`run_payload_experiment` simulates.

    Bit-identical to that run in the study (same seeds, one BLAS thread), so it can
    be handed to the study as ``known`` (e.g. one rollout needed early for a video).
    """
    (outcome,) = map_items(
        functools.partial(_run_one, cfg), [(controller, payload_kg)],
        labels=[f"{controller} {payload_kg:g} kg"], quiet=True,
    )  # fmt: skip
    if not outcome.ok:
        raise DexlfdError(f"payload study: {outcome.label}: {outcome.error}")
    return outcome.value[2]


def run_payload_experiment(
    cfg: PayloadConfig,
    callback: Callable[[int, float], None] | None = None,
    *,
    quiet: bool = True,
    known: Mapping[tuple[str, float], Rollout] | None = None,
) -> PayloadResult:
    """Run every controller at every payload and compute Table 5.1's figures.

    The runs go to ``cfg.engine`` with ``cfg.workers``. ``callback(i, seconds)``
    is called after each finished run; ``quiet=False`` shows a progress bar.
    ``known`` rollouts, by (controller, payload), are used as given instead of
    simulated again (from :func:`run_payload_rollout` with the same ``cfg``).

    Raises
    ------
    DexlfdError
        A run failed (not a safety stop, which is a result): the message lists
        which and why.
    """
    known = dict(known or {})
    pairs = [(c, p) for c in cfg.controllers for p in cfg.payloads]
    jobs = [job for job in pairs if job not in known]
    outcomes = map_items(  # the config (and its plan) goes to each worker once, in the partial
        functools.partial(_run_one, cfg), jobs, labels=[f"{c} {p:g} kg" for c, p in jobs],
        engine=cfg.engine, workers=cfg.workers, address=cfg.ray_address,
        desc="payload study", quiet=quiet, callback=callback,
    )  # fmt: skip
    failures = format_failures(outcomes)
    if failures:
        raise DexlfdError("payload study: " + failures.replace("\n", ";"))
    simulated = {(c, p): ro for c, p, ro in (o.value for o in outcomes)}
    rollouts = {pair: known[pair] if pair in known else simulated[pair] for pair in pairs}
    rows: list[PayloadRow] = []
    for c in cfg.controllers:
        base = rollouts[(c, 0.0)]
        m0 = lift_metrics(base, cfg.clearance)
        for p in cfg.payloads:
            if p == 0.0:
                continue
            ro = rollouts[(c, p)]
            stopped = ro.stopped or base.stopped or _not_carried(ro)
            m1 = lift_metrics(ro, cfg.clearance) if ro.n_samples == base.n_samples else None
            if m1 is None:
                nan = float("nan")
                rows.append(
                    PayloadRow(c, p, m0["e_z"], nan, nan, nan, nan, nan, nan, nan, nan, stopped)
                )
                continue
            e0, e1 = m0["e_z"], m1["e_z"]
            sag = float(np.mean((m1["z_err"] - m0["z_err"])[m0["mask"]]))
            rows.append(
                PayloadRow(
                    controller=c,
                    payload_kg=p,
                    e_nob_m=e0,
                    e_ob_m=e1,
                    delta_ob_pct=100.0 * (e1 - e0) / e0,  # [1] Eq. (5.28)
                    delta_e_m=e1 - e0,
                    sag_m=sag,
                    max_abs_z_error_m=m1["max_abs_z"],
                    rms_orientation_error_rad=m1["rot_rms"],
                    max_orientation_error_rad=m1["rot_max"],
                    max_torque_rate_nm_per_s=m1["torque_rate_max"],
                    stopped=stopped,
                    slip_m=carry_slip(ro),
                )
            )
    heavy = max(cfg.payloads)
    ours = [
        r for r in rows
        if r.payload_kg == heavy and r.controller not in THESIS_LAWS
        and r.stopped is None and np.isfinite(r.e_ob_m)
    ]  # fmt: skip
    best = min(ours, key=lambda r: r.e_ob_m).controller if ours else None
    for r in rows:
        logger.info(
            "%-12s %.2f kg  E_NOB %.3f mm  E_OB %.3f mm  dE %+.3f mm",
            r.controller, r.payload_kg, 1e3 * r.e_nob_m, 1e3 * r.e_ob_m, 1e3 * r.delta_e_m,
        )  # fmt: skip
    return PayloadResult(rows=rows, rollouts=rollouts, config=cfg, best=best)


def format_table(result: PayloadResult) -> str:
    """Plain-text table (mm) beside the thesis's real-robot figures."""
    cfg = result.config
    lines = [
        "Table 5.1 in simulation: z-axis RMSE while the object is carried over the obstacle",
        f"plant: Gaz et al. 2019 joint friction x{cfg.friction_scale:g}, controller model "
        f"mass/inertia error {100 * cfg.model_error:.0f} %, noise q {cfg.q_noise:g} rad / "
        f"dq {cfg.dq_noise:g} rad/s, torque delay {cfg.torque_delay} tick(s), torque rate "
        f"<= 1000 N m/s, contacts "
        f"{'on' if cfg.contacts else 'off'}; {_grasp_words(cfg)}"
        + (
            f"friction) at t = 0 (lift start), {cfg.duration:g} s lift, 1 kHz"
            if cfg.plan is None
            else f"friction) when the plan closes the gripper, "
            f"{float(cfg.plan.t[-1] - cfg.plan.t[0]):.2f} s plan, 1 kHz"
        ),
        "",
        f"{'kg':>5} {'controller':<12} {'E_NOB':>7} {'E_OB':>7} {'Δ_OB':>8} {'ΔE':>7} "
        f"{'sag':>7} {'rot max':>7} | {'thesis E_NOB':>12} {'E_OB':>6} {'Δ_OB':>8} {'ΔE':>6}",
        f"{'':>5} {'':<12} {'mm':>7} {'mm':>7} {'%':>8} {'mm':>7} {'mm':>7} {'deg':>7} | "
        f"{'mm':>12} {'mm':>6} {'%':>8} {'mm':>6}",
    ]
    for r in sorted(result.rows, key=lambda r: (r.payload_kg, cfg.controllers.index(r.controller))):
        th = THESIS_TABLE.get((r.controller, r.payload_kg))
        ths = (
            f"{1e3 * th[0]:>12.2f} {1e3 * th[1]:>6.2f} {th[2]:>7.2f}% "
            f"{1e3 * (th[1] - th[0]):>+6.1f}"
            if th
            else f"{'—':>12} {'—':>6} {'—':>8} {'—':>6}"
        )
        mark = " *" if r.controller == result.best and r.payload_kg == max(cfg.payloads) else ""
        lines.append(
            f"{r.payload_kg:>5.2f} {r.controller:<12} {1e3 * r.e_nob_m:>7.3f} "
            f"{1e3 * r.e_ob_m:>7.3f} "
            f"{r.delta_ob_pct:>7.1f}% {1e3 * r.delta_e_m:>+7.3f} {1e3 * r.sag_m:>+7.2f} "
            f"{np.degrees(r.max_orientation_error_rad):>7.2f} | {ths}{mark}"
            + (
                ""
                if not r.stopped
                else f"  {r.stopped}"
                if r.stopped.startswith("NOT CARRIED")
                else f"  STOPPED: {r.stopped}"
            )
        )
    if result.best:
        lines.append(f"* best of ours at {max(cfg.payloads):g} kg: {result.best}")
    kp = make_controller("pd").describe()["K_p"]
    lines.append(
        f"closed form for PD: sag = weight / K_p = {1e3 * 9.81 * max(cfg.payloads) / kp:.2f} mm "
        f"at {max(cfg.payloads):g} kg"
    )
    return "\n".join(lines)


def _grasp_words(cfg: PayloadConfig) -> str:
    """How the object is held, for the table's header."""
    if cfg.hand == "softhand":
        return f"a {cfg.shape} wrapped by the qb SoftHand ({cfg.stop_force:g} N squeeze, "
    return f"a {cfg.shape} grasped by the fingers (70 N, "


def rows_as_json(rows: Sequence[PayloadRow]) -> list[dict[str, Any]]:
    """Rows as JSON-able dicts (the ``--json`` output)."""
    # NaN (a run that stopped) is not valid JSON (RFC 8259): write null
    return [
        {
            k: None if isinstance(v, float) and not np.isfinite(v) else v
            for k, v in r.json_row().items()
        }
        for r in rows
    ]
