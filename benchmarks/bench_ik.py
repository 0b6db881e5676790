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
``--compare SRC`` also times the ``dexlfd/panda_ik.py`` of another checkout's ``src``
folder (e.g. ``git archive main``; on this checkout's robot models), its rounds
interleaved with this one's in the same process, and prints the median of the ratios
round by round (this / other). Run with the venv's python::

    PYTHONPATH=src python benchmarks/bench_ik.py [--repeat 7] [--compare OTHER/src]
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np

from dexlfd import panda_ik
from dexlfd.panda import Q_MAX, Q_MIN, Q_READY
from dexlfd.panda_ik import KinematicModel
from dexlfd.panda_kinematics import DhPanda


def _cpu_per_call(fns: list[Callable[[], int]], calls: int, repeat: int) -> list[list[float]]:
    """Per function, the process CPU time per call [µs] of each round (rounds interleaved)."""
    for fn in fns:
        fn()  # warm-up
    runs: list[list[float]] = [[] for _ in fns]
    for _ in range(repeat):
        for fn, out in zip(fns, runs, strict=True):
            t0 = time.process_time()
            fn()
            out.append((time.process_time() - t0) / calls * 1e6)
    return runs


def _other(src: str) -> ModuleType:
    """``SRC/dexlfd/panda_ik.py`` of another checkout, as its own module."""
    spec = importlib.util.spec_from_file_location(
        "other_panda_ik", Path(src) / "dexlfd/panda_ik.py"
    )
    if spec is None or spec.loader is None:
        raise SystemExit(f"--compare: no dexlfd/panda_ik.py under {src}")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def _path(model: KinematicModel) -> tuple[np.ndarray, np.ndarray]:
    """TCP positions (81, 3) and rotations (81, 3, 3) of a 0.36 m move from the ready pose."""
    p0, R0 = model.tcp_pose(Q_READY)
    s = np.clip(np.linspace(0.0, 4.0, 81) / 3.0, 0.0, 1.0)
    s = s * s * (3.0 - 2.0 * s)
    return p0 + s[:, None] * np.array([0.0, 0.35, -0.1]), np.repeat(R0[None], 81, axis=0)


def _cases(model: KinematicModel, ik: ModuleType) -> dict[str, tuple[Callable[[], int], int]]:
    """name -> (a round returning the iterations taken, calls in the round), with ``ik``."""
    solve_ik, solve_ik_batch = ik.solve_ik, ik.solve_ik_batch
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
    ap.add_argument("--compare", metavar="SRC", help="also time SRC/dexlfd/panda_ik.py")
    args = ap.parse_args()
    iks = [panda_ik] if args.compare is None else [panda_ik, _other(args.compare)]
    models: list[tuple[str, KinematicModel]] = [("DhPanda", DhPanda())]
    try:
        from dexlfd.robot import MujocoPandaModel

        models.append(("MuJoCo", MujocoPandaModel()))
    except Exception as exc:  # noqa: BLE001 - MuJoCo is an extra
        print(f"MuJoCo Panda skipped: {exc}")
    print(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for name, model in models:
        cases = [_cases(model, ik) for ik in iks]
        for case, (fn, calls) in cases[0].items():
            iters = fn() / calls
            fns = [c[case][0] for c in cases]
            runs = _cpu_per_call(fns, calls, args.repeat)
            extra = f", {iters:.1f} iterations a call" if iters else " (81 rows)"
            line = f"{name:8s} {case:6s} {np.median(runs[0]):9.1f} µs CPU a call{extra}"
            if len(runs) > 1:
                ratio = np.median(np.divide(runs[0], runs[1]))
                line += f"; other {np.median(runs[1]):9.1f} µs, this / other {ratio:.2f}"
            print(line)
    print(f"load average at end:   {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
