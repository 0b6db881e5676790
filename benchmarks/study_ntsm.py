"""NTSM-PD vs SM-PD: Table 5.1 per reading of the printed laws, and under which conditions.

Runs the payload study (:mod:`dexlfd.experiments.payload`, the documented
realistic plant) for PD, SM-PD and NTSM-PD under every reading of Eqs. (5.17)
and (5.25) (registry keys ``*-det``, ``*-matrix``, ``sm-pd-slope``) and the joint-space
SM law of Eqs. (5.21)-(5.22) as printed (``sm-joint``, beside ``joint-pd``), then a
sweep of gains and plant conditions at 1.2 kg, and draws s, ė and the switching
force during the lift (``docs/figures/ntsm_vs_sm_lift.png``).

Usage::

    PYTHONPATH=src python benchmarks/study_ntsm.py [--quick] [--figure PATH] [--workers N]

Everything is simulated time with fixed seeds: the numbers are reproducible.
"""

from __future__ import annotations

import argparse
import logging
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from dexlfd.control import TrackingStopped, make_controller, track
from dexlfd.control.base import Reference, RobotState, minv_jt
from dexlfd.errors import InvalidInput
from dexlfd.experiments.payload import PayloadConfig, lift_metrics
from dexlfd.robot import perturbed_model
from dexlfd.robot.robot_model import ModelTerms

MM = 1e3
TABLE_CONTROLLERS = (
    "pd", "sm-pd", "ntsm-pd", "sm-pd-det", "ntsm-pd-det", "sm-pd-matrix", "ntsm-pd-matrix",
    "sm-pd-slope", "ntsm-pd-i", "ntsm-pd-dob", "joint-pd", "sm-joint",
)  # fmt: skip


@dataclass
class _Probe:
    """Wraps a sliding-mode law and records s, ė and the switching force every tick."""

    inner: Any
    log: list[tuple[float, float, float, float, float]]

    @property
    def name(self) -> str:
        return str(self.inner.name)

    @property
    def needs_joint_reference(self) -> bool:
        return False

    def init(self, robot_state: RobotState, terms: ModelTerms) -> Any:
        return self.inner.init(robot_state, terms)

    def step(
        self, ctrl_state: Any, robot_state: RobotState, reference: Reference, terms: ModelTerms
    ) -> tuple[np.ndarray, Any]:
        from dexlfd.control.sliding_mode import lambda_force

        e = terms.p - reference.p
        de = terms.J[:3] @ robot_state.dq - reference.v
        s, a_eq = self.inner._surface(e, de)
        sat = np.tanh(self.inner.k_s * s)
        Lam_inv = terms.J @ minv_jt(terms)
        Mp = np.linalg.inv(Lam_inv[:3, :3])
        f_sw = -(Mp @ (self.inner.kappa * sat)) - lambda_force(
            Mp, self.inner.lam, sat, self.inner.reading
        )
        f_eq = Mp @ a_eq
        self.log.append((robot_state.t, e[2], de[2], s[2], f_sw[2], f_eq[2]))  # type: ignore[arg-type]
        return self.inner.step(ctrl_state, robot_state, reference, terms)  # type: ignore[no-any-return]

    def describe(self) -> dict[str, Any]:
        return dict(self.inner.describe())


def run(
    name: str, payload: float, cfg: PayloadConfig, gains: dict[str, Any] | None = None,
    probe: bool = False,
) -> tuple[Any, np.ndarray | None]:  # fmt: skip
    """One rollout like the payload study's, optionally with a probe; returns (rollout, log)."""
    model = perturbed_model(cfg.model_error, np.random.default_rng([cfg.seed, 1]))
    ctrl: Any = make_controller(name, **(gains or {}))
    log: list[Any] = []
    if probe:
        ctrl = _Probe(ctrl, log)
    try:
        ro = track(
            cfg.tracked_plan(), ctrl, model, cfg.plant(payload), cfg.loop(),
            rng=np.random.default_rng([cfg.seed, 2]),
        )  # fmt: skip
    except TrackingStopped as exc:
        ro = exc.rollout
    return ro, (np.array(log) if probe else None)


def _job(args: tuple[str, float, PayloadConfig, dict[str, Any]]) -> tuple[float, float, str]:
    name, payload, cfg, gains = args
    ro, _ = run(name, payload, cfg, gains)
    try:
        m = lift_metrics(ro, cfg.clearance)
    except InvalidInput:  # stopped before the window
        return float("nan"), float("nan"), str(ro.stopped or "no window")
    return m["e_z"], float(np.mean(m["z_err"][m["mask"]])), str(ro.stopped or "")


def table(
    cfg: PayloadConfig, names: tuple[str, ...], gains: dict[str, Any], workers: int
) -> dict[tuple[str, float], tuple[float, float, str]]:
    """E [m], mean z error [m] and stop reason per (controller, payload)."""
    jobs = [(n, p, cfg, gains if n != "pd" else {}) for n in names for p in cfg.payloads]
    if workers > 1:
        with ProcessPoolExecutor(workers) as pool:
            out = list(pool.map(_job, jobs))
    else:
        out = [_job(j) for j in jobs]
    return {(j[0], j[1]): o for j, o in zip(jobs, out, strict=True)}


def print_table(res: dict[tuple[str, float], tuple[float, float, str]], title: str) -> None:
    """Table 5.1 layout: E_NOB, E_OB, ΔE per payload [mm]."""
    print(f"\n{title}")
    names = sorted({k[0] for k in res}, key=lambda n: TABLE_CONTROLLERS.index(n)
                   if n in TABLE_CONTROLLERS else 99)  # fmt: skip
    loads = sorted({k[1] for k in res})
    print(
        f"{'controller':<16} {'E_NOB':>7}"
        + "".join(f" | {p:.2f} kg: {'E_OB':>6} {'ΔE':>7} {'mean e_z':>8}" for p in loads if p > 0)
    )
    for n in names:
        e0 = res[(n, 0.0)][0]
        row = f"{n:<16} {MM * e0:7.3f}"
        for p in loads:
            if p == 0:
                continue
            e1, mz, stop = res[(n, p)]
            row += f" | {'':>8} {MM * e1:6.3f} {MM * (e1 - e0):+7.3f} {MM * mz:+8.3f}"
            if stop:
                row += f" STOPPED({stop[:30]})"
        print(row)


def figure(cfg: PayloadConfig, path: str) -> None:
    """s, ė and the switching / equivalent-control forces (z) during the 1.2 kg lift."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    for name, style in (("sm-pd", "C0"), ("ntsm-pd", "C3"), ("ntsm-pd-det", "C2")):
        ro, log = run(name, 1.2, cfg, probe=True)
        assert log is not None
        m = lift_metrics(ro, cfg.clearance)
        t = log[:, 0]
        lab = f"{name} (E_OB {MM * m['e_z']:.2f} mm)"
        ax[0].plot(t, MM * log[:, 1], style, lw=0.8, label=lab)
        ax[1].plot(t, MM * log[:, 2], style, lw=0.5, label=name)
        ax[2].plot(t, MM * log[:, 3], style, lw=0.8, label=name)
        ax[3].plot(t, log[:, 4], style, lw=0.8, label=f"{name}: switching −(M̄κ+λ·)tanh(k_s s)")
        ax[3].plot(t, log[:, 5], style, lw=0.5, ls=":", label=f"{name}: M̄ ë_eq")
        win = t[m["mask"][: t.size]]
        for a in ax:
            a.axvspan(win[0], win[-1], color="0.92", zorder=-1)
    ax[0].set_ylabel("e_z [mm]")
    ax[1].set_ylabel("ė_z [mm/s]")
    ax[1].set_ylim(-30, 30)
    ax[2].set_ylabel("s_z [mm]")
    ax[3].set_ylabel("F_z [N]")
    ax[3].set_xlabel("t [s] (grey: the Eq. 5.27 window)")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=7, loc="best")
    ax[0].set_title("1.2 kg lift, realistic plant: sliding variable and forces (z)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"figure: {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="Table 5.1 only, no sweep")
    ap.add_argument("--figure", default=None, help="write the s/ė/switching figure here")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--sweep-only", action="store_true", help="skip the Table 5.1 part")
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    base = PayloadConfig()
    if not args.sweep_only:
        res = table(base, TABLE_CONTROLLERS, {}, args.workers)
        print_table(res, "Table 5.1, realistic plant (default), every reading")
    if args.figure:
        figure(base, args.figure)
    if args.quick:
        return
    pair = ("pd", "sm-pd", "ntsm-pd", "ntsm-pd-det")
    heavy = replace(base, payloads=(0.0, 1.2))
    sweeps: list[tuple[str, PayloadConfig, dict[str, Any]]] = [
        ("ideal plant: no friction, exact model, no noise/delay",
         replace(heavy, friction_scale=0.0, model_error=0.0, q_noise=0.0, dq_noise=0.0,
                 torque_delay=0), {}),
        ("friction x3", replace(heavy, friction_scale=3.0), {}),
        ("torque delay 3 ticks", replace(heavy, torque_delay=3), {}),
        ("model error 30 %", replace(heavy, model_error=0.3), {}),
        ("k_s = 2 (wide boundary layer)", heavy, {"k_s": 2.0}),
        ("k_s = 50", heavy, {"k_s": 50.0}),
        ("kappa = 10, lam = 6", heavy, {"kappa": 10.0}),
        ("beta = 1.0", heavy, {"beta": 1.0}),
        ("alpha = 1.2", heavy, {"alpha": 1.2}),
        ("fast lift: 2 s", replace(heavy, duration=2.0), {}),
    ]  # fmt: skip
    for title, cfg, gains in sweeps:
        print_table(table(cfg, pair, gains, args.workers), f"{title} {gains or ''}")


if __name__ == "__main__":
    main()
