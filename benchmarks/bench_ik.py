"""The TCP inverse kinematics: one solve at a time and a batch of starts (CPU per call).

What the planner asks of :mod:`dexlfd.panda_ik`, on both robot models it is used with
(Table 3.1's :class:`~dexlfd.panda_kinematics.DhPanda` and the MuJoCo Panda
``dexlfd.robot.MujocoPandaModel``):

- ``track``: ``solve_ik`` along a 0.36 m TCP move sampled at 20 Hz, each solve from
  the previous sample's joints (``max_iter=50``), as the plan's joint profile and the
  elbow posture's start-posture pass do: a few iterations a call;
- ``cold``: ``solve_ik`` from the ready pose to poses ~0.3 rad of joint motion away
  (``max_iter=300``): tens of iterations a call;
- ``batch``: ``solve_ik_batch`` of 81 starts along the elbow's self-motion carried to
  the next sample's pose (``max_iter=30``), as the posture search's columns are.

Printed: the median over repeats of the CPU time per call [µs] (process time, after
a warm-up), the mean iterations a call, and the load average (the machine is shared).
Run with the venv's python::

    PYTHONPATH=src python benchmarks/bench_ik.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

import numpy as np

from dexlfd.panda import Q_MAX, Q_MIN, Q_READY
from dexlfd.panda_ik import KinematicModel, solve_ik, solve_ik_batch
from dexlfd.panda_kinematics import DhPanda


def _cpu_per_call(fn: Callable[[], int], calls: int, repeat: int) -> float:
    """Median over ``repeat`` rounds of the process CPU time per call [µs]."""
    fn()  # warm-up
    runs = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        runs.append((time.process_time() - t0) / calls * 1e6)
    return float(np.median(runs))


def _path(model: KinematicModel) -> tuple[np.ndarray, np.ndarray]:
    """TCP positions (81, 3) and rotations (81, 3, 3) of a 0.36 m move from the ready pose."""
    p0, R0 = model.tcp_pose(Q_READY)
    s = np.clip(np.linspace(0.0, 4.0, 81) / 3.0, 0.0, 1.0)
    s = s * s * (3.0 - 2.0 * s)
    return p0 + s[:, None] * np.array([0.0, 0.35, -0.1]), np.repeat(R0[None], 81, axis=0)


def _cases(model: KinematicModel) -> dict[str, tuple[Callable[[], int], int]]:
    """name -> (a round returning the iterations taken, calls in the round)."""
    P, R = _path(model)
    rng = np.random.default_rng(0)
    far = np.clip(Q_READY + rng.normal(0.0, 0.3, (20, 7)), Q_MIN + 0.1, Q_MAX - 0.1)
    targets = [model.tcp_pose(q) for q in far]
    q_mid = solve_ik(model, P[40], R[40], Q_READY).q
    starts = np.clip(q_mid + rng.normal(0.0, 0.05, (81, 7)), Q_MIN, Q_MAX)

    def track() -> int:
        q, n = Q_READY, 0
        for k in range(P.shape[0]):
            ik = solve_ik(model, P[k], R[k], q, max_iter=50)
            q, n = ik.q, n + ik.n_iter
        return n

    def cold() -> int:
        return sum(solve_ik(model, p, Rt, max_iter=300).n_iter for p, Rt in targets)

    def batch() -> int:
        solve_ik_batch(model, P[41], R[41], starts, max_iter=30)
        return 0

    return {"track": (track, P.shape[0]), "cold": (cold, len(targets)), "batch": (batch, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=7, help="rounds timed per case (median)")
    args = ap.parse_args()
    models: list[tuple[str, KinematicModel]] = [("DhPanda", DhPanda())]
    try:
        from dexlfd.robot import MujocoPandaModel

        models.append(("MuJoCo", MujocoPandaModel()))
    except Exception as exc:  # noqa: BLE001 - MuJoCo is an extra
        print(f"MuJoCo Panda skipped: {exc}")
    print(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for name, model in models:
        for case, (fn, calls) in _cases(model).items():
            iters = fn() / calls
            us = _cpu_per_call(fn, calls, args.repeat)
            extra = f", {iters:.1f} iterations a call" if iters else " (81 rows)"
            print(f"{name:8s} {case:6s} {us:9.1f} µs CPU a call{extra}")
    print(f"load average at end:   {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
