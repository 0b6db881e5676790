"""Table 5.1 over the Franka protocol: the payload study on franky-sim via pylibfranka.

Each controller tracks the payload study's lift plan
(:func:`~dexlfd.plan.moves.lift_plan`) on a fresh ``franky-sim`` (MuJoCo
FR3, joint friction) started at the plan's first pose, through libfranka's torque
loop (:func:`~dexlfd.control.franka.track_franka`), with an extra body on the hand
that neither the simulator's gravity compensation nor libfranka's model knows.
The controller's model is libfranka's. Metrics as in
:mod:`dexlfd.experiments.payload` (z RMSE while carried, Eq. 5.27; ΔE; sag),
computed after resampling each rollout onto the plan's 1 kHz grid (cycles the
host missed are interpolated over).

References
----------
.. [1] Thesis §5.3.3, Eqs. (5.27)–(5.28), Table 5.1.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.experiments.payload import lift_metrics
from dexlfd.io import Plan, Rollout
from dexlfd.plan.moves import lift_plan
from dexlfd.trajectory import resample

__all__ = [
    "FR3_Q_MAX",
    "FR3_Q_MIN",
    "ProtocolPayloadConfig",
    "ProtocolPayloadResult",
    "format_protocol_table",
    "on_grid",
    "run_protocol_payload",
    "start_joints",
]

logger = logging.getLogger(__name__)

# FR3 joint limits [rad] (franky-sim simulates an FR3; Franka's FR3 datasheet)
FR3_Q_MIN = np.array([-2.7437, -1.7837, -2.9007, -3.0421, -2.8065, 0.5445, -3.0159])
FR3_Q_MAX = np.array([2.7437, 1.7837, 2.9007, -0.1518, 2.8065, 4.5169, 3.0159])


@dataclass(frozen=True, slots=True)
class ProtocolPayloadConfig:
    """Settings of the payload study over the protocol.

    Attributes
    ----------
    controllers : tuple of str
        Registry names.
    payloads : tuple of float
        Unknown payload masses [kg]; must include 0.
    duration : float
        Lift time [s].
    clearance : float
        Metrics window: reference z at least this far above the start [m].
    sim_root : Path
        Cache folder of the simulator's environment.
    lockstep_s : float or None
        None: the simulator runs in real time (missed cycles are lost, as on a
        robot); a value: it waits that long for each command (host-independent).
    """

    controllers: tuple[str, ...] = ("pd", "ntsm-pd")
    payloads: tuple[float, ...] = (0.0, 0.45, 1.2)
    duration: float = 6.0
    clearance: float = 0.05
    sim_root: Path = Path(".venv-franka-sim")
    lockstep_s: float | None = None

    def __post_init__(self) -> None:
        from dexlfd.control import make_controller

        if 0.0 not in self.payloads:
            raise InvalidInput(f"payloads must include 0.0 (no object), got {self.payloads}")
        if any(not (0.0 <= m <= 3.0) for m in self.payloads):
            raise InvalidInput(f"payloads must be in [0, 3] kg, got {self.payloads}")
        for name in self.controllers:
            make_controller(name)  # raises on unknown names


@dataclass(frozen=True, slots=True)
class ProtocolPayloadResult:
    """Rows (JSON-able dicts), the rollouts on the plan grid and each run's loop figures."""

    rows: list[dict[str, Any]]
    rollouts: dict[tuple[str, float], Rollout]
    loops: dict[tuple[str, float], dict[str, float]]
    config: ProtocolPayloadConfig
    notes: list[str] = field(default_factory=list)


def start_joints(plan: Plan) -> FloatArray:
    """IK joints [rad] of the plan's first TCP pose, within the FR3's limits."""
    from dexlfd.control.reference import resample_plan
    from dexlfd.robot import MujocoPandaModel, solve_ik

    ref = resample_plan(plan, 1e-3)
    ik = solve_ik(MujocoPandaModel(), ref.p[0], ref.R[0])
    if not ik.converged or ((ik.q < FR3_Q_MIN) | (ik.q > FR3_Q_MAX)).any():
        raise InvalidInput(
            f"no FR3-feasible IK solution for the plan's start {np.round(ref.p[0], 3).tolist()} m"
        )
    return ik.q


def on_grid(rollout: Rollout, t: FloatArray) -> Rollout:
    """The rollout linearly interpolated to times ``t`` [s] (quaternions renormalised)."""

    def f(x: FloatArray) -> FloatArray:
        return resample(t, rollout.t, x)

    qe, qr = f(rollout.ee_quaternion), f(rollout.ref_quaternion)
    extras = {}
    if "orientation_error" in rollout.extras:
        extras["orientation_error"] = np.interp(t, rollout.t, rollout.extras["orientation_error"])
    return Rollout(
        t=t, q=f(rollout.q), dq=f(rollout.dq), tau=f(rollout.tau),
        ee_position=f(rollout.ee_position),
        ee_quaternion=qe / np.linalg.norm(qe, axis=1, keepdims=True),
        ref_position=f(rollout.ref_position),
        ref_quaternion=qr / np.linalg.norm(qr, axis=1, keepdims=True),
        gripper=np.interp(t, rollout.t, rollout.gripper), meta=rollout.meta, extras=extras,
        **{name: getattr(rollout, name) for name in Rollout.FACTS},
    )  # fmt: skip


def run_protocol_payload(
    cfg: ProtocolPayloadConfig, callback: Callable[[int, float], None] | None = None
) -> ProtocolPayloadResult:
    """Run every controller at every payload over the protocol; Table 5.1's figures.

    Raises
    ------
    SimulatorUnavailable
        If the simulator's environment cannot be created.
    """
    from dexlfd.control import make_controller
    from dexlfd.control.franka import track_franka
    from dexlfd.control.reference import resample_plan
    from dexlfd.robot.franka import FrankaArm
    from dexlfd.robot.franka_sim import FrankaSimServer, ensure_simulator_venv
    from dexlfd.robot.libfranka import RobotStopped

    python = ensure_simulator_venv(cfg.sim_root)
    plan = lift_plan(cfg.duration)
    grid = resample_plan(plan, 1e-3).t
    q0 = start_joints(plan)
    rollouts: dict[tuple[str, float], Rollout] = {}
    loops: dict[tuple[str, float], dict[str, float]] = {}
    stopped: dict[tuple[str, float], str] = {}
    i = 0
    for c in cfg.controllers:
        for m in cfg.payloads:
            with (
                FrankaSimServer(
                    python, payload_kg=m, q0=q0.tolist(), lockstep_s=cfg.lockstep_s
                ) as sim,
                FrankaArm(sim.host) as arm,
            ):
                try:
                    ro, stats = track_franka(arm, plan, make_controller(c))
                    loops[(c, m)] = stats.summary()
                    rollouts[(c, m)] = on_grid(ro, grid)
                except RobotStopped as exc:
                    stopped[(c, m)] = str(exc)
                    logger.error("%s at %g kg stopped: %s", c, m, exc)
            if callback is not None:
                callback(i, 0.0)
            i += 1
    rows: list[dict[str, Any]] = []
    for c in cfg.controllers:
        if (c, 0.0) not in rollouts:  # no baseline: every row of this law reports the stop
            for m in cfg.payloads:
                if m != 0.0:
                    why = stopped.get((c, m)) or f"no-load run: {stopped.get((c, 0.0))}"
                    rows.append({"controller": c, "payload_kg": m, "stopped": why})
            continue
        m0 = lift_metrics(rollouts[(c, 0.0)], cfg.clearance)
        for m in cfg.payloads:
            if m == 0.0:
                continue
            row: dict[str, Any] = {"controller": c, "payload_kg": m, "e_nob_m": m0["e_z"]}
            if (c, m) not in rollouts:
                row["stopped"] = stopped.get((c, m), "no rollout")
                rows.append(row)
                continue
            m1 = lift_metrics(rollouts[(c, m)], cfg.clearance)
            row.update(
                e_ob_m=m1["e_z"],
                delta_ob_pct=100.0 * (m1["e_z"] - m0["e_z"]) / m0["e_z"],  # [1] Eq. (5.28)
                delta_e_m=m1["e_z"] - m0["e_z"],
                sag_m=float(np.mean((m1["z_err"] - m0["z_err"])[m0["mask"]])),
                rate_hz=loops[(c, m)]["rate_hz"],
                missed_cycles=loops[(c, m)]["missed_cycles"],
                compute_us_median=loops[(c, m)]["compute_us_median"],
            )
            rows.append(row)
    return ProtocolPayloadResult(rows=rows, rollouts=rollouts, loops=loops, config=cfg)


def format_protocol_table(result: ProtocolPayloadResult) -> str:
    """Plain-text table (mm) of the study over the protocol."""
    cfg = result.config
    mode = "real time" if cfg.lockstep_s is None else f"lock-step ({cfg.lockstep_s:g} s)"
    lines = [
        "Table 5.1 over the Franka protocol: z-axis RMSE while the object is carried",
        f"pylibfranka 0.21.3 <-> franky-sim 1.0.4 (MuJoCo FR3, joint friction; {mode}); "
        f"controller model: libfranka's; payload unknown to both; {cfg.duration:g} s lift",
        "",
        f"{'kg':>5} {'controller':<10} {'E_NOB':>7} {'E_OB':>7} {'Δ_OB':>8} {'ΔE':>7} "
        f"{'sag':>7} {'Hz':>5} {'missed':>6} {'µs':>5}",
    ]
    for r in sorted(result.rows, key=lambda r: (r["payload_kg"], r["controller"])):
        if "stopped" in r:
            stop = r["stopped"]
            lines.append(f"{r['payload_kg']:>5.2f} {r['controller']:<10} STOPPED: {stop}")
            continue
        lines.append(
            f"{r['payload_kg']:>5.2f} {r['controller']:<10} {1e3 * r['e_nob_m']:>7.3f} "
            f"{1e3 * r['e_ob_m']:>7.3f} {r['delta_ob_pct']:>7.1f}% {1e3 * r['delta_e_m']:>+7.3f} "
            f"{1e3 * r['sag_m']:>+7.2f} {r['rate_hz']:>5.0f} {r['missed_cycles']:>6.0f} "
            f"{r['compute_us_median']:>5.0f}"
        )
    return "\n".join(lines)
