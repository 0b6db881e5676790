"""Cost of one 1 kHz control tick (model terms + law) and the closed-loop speed.

The machine is shared: besides wall-clock medians we report CPU time
(``time.process_time``), which does not count the time the process waits for
a core, and the best of the repeats.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from dexlfd.control import LoopConfig, RobotState, make_controller, resample_plan, track
from dexlfd.control.base import Reference
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import MujocoPandaModel, PlantConfig, perturbed_model, solve_ik

REPEAT, NUMBER = 9, 2000


def _measure(fn: Callable[[], None]) -> tuple[float, float, float]:
    """(median wall, median CPU, best CPU) per call [µs]."""
    walls, cpus = [], []
    for _ in range(REPEAT):
        w0, c0 = time.perf_counter(), time.process_time()
        for _ in range(NUMBER):
            fn()
        walls.append((time.perf_counter() - w0) / NUMBER * 1e6)
        cpus.append((time.process_time() - c0) / NUMBER * 1e6)
    return float(np.median(walls)), float(np.median(cpus)), float(np.min(cpus))


def _tick(name: str, model: MujocoPandaModel) -> Callable[[], None]:
    ref = resample_plan(lift_plan(6.0), 1e-3)
    q0 = solve_ik(model, ref.p[0], ref.R[0]).q
    rng = np.random.default_rng(0)
    c = make_controller(name)
    k = 3000
    r = Reference(ref.p[k], ref.v[k], ref.a[k], ref.R[k], ref.w[k])
    q = q0 + rng.normal(0, 0.01, 7)
    dq = rng.normal(0, 0.1, 7)
    box = {"st": c.init(RobotState(0.0, q0, np.zeros(7)), model.terms(q0, np.zeros(7))), "t": 0.0}

    def one() -> None:
        box["t"] += 1e-3
        terms = model.terms(q, dq)
        _, box["st"] = c.step(box["st"], RobotState(box["t"], q, dq), r, terms)

    return one


def main() -> None:
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):  # as the control loop does
        _main()


def _main() -> None:
    model = MujocoPandaModel()
    q, dq = np.full(7, 0.1), np.ones(7)
    print(f"{'per call [µs]':<44} {'wall med':>9} {'CPU med':>8} {'CPU best':>9}")
    w, c, b = _measure(lambda: model.terms(q, dq))
    print(f"{'model terms (M, h, g, J, J̇q̇, M⁻¹Jᵀ, pose)':<44} {w:9.1f} {c:8.1f} {b:9.1f}")
    for name in ("pd", "sm-pd", "ntsm-pd", "ntsm-pd-i", "ntsm-pd-dob"):
        w, c, b = _measure(_tick(name, model))
        print(f"{'tick: terms + ' + name + ' law':<44} {w:9.1f} {c:8.1f} {b:9.1f}")
    plan = lift_plan(6.0)
    for name in ("ntsm-pd", "ntsm-pd-dob"):
        walls, cpus = [], []
        for _ in range(3):
            pert = perturbed_model(0.1, np.random.default_rng(1))
            w0, c0 = time.perf_counter(), time.process_time()
            track(plan, make_controller(name), pert, PlantConfig(payload_kg=1.2), LoopConfig(),
                  rng=np.random.default_rng(0))  # fmt: skip
            walls.append(time.perf_counter() - w0)
            cpus.append(time.process_time() - c0)
        wall, cpu = float(np.median(walls)), float(np.median(cpus))
        print(f"closed loop, 6 s lift at 1 kHz, 1.2 kg, {name:<12}: wall {wall:.2f} s "
              f"({6 / wall:.1f}x real time), CPU {cpu:.2f} s ({6 / cpu:.1f}x)")  # fmt: skip


if __name__ == "__main__":
    main()
