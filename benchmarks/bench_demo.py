"""Wall and CPU time of `dexlfd demo` per stage (fresh run, 2 workers); target < 40 s.

``capture``, ``video`` and ``generalize`` run in background processes (their times
overlap the others'), so the total is less than the sum of the stages. The CPU time
(this process and every process it waited for: stages, simulation workers, ffmpeg)
hardly depends on what else the machine runs; on a busy machine compare it, and the
stages as ratios of one run; the load average is printed. A stage's CPU column counts
its own process and the children it waited for; the simulation workers of ``control``
and ``generalize`` are children of the engine's fork server, not of the stage, so
their CPU is not in it (those two stages' wall times are the figure to compare).
``--numba-cold`` compiles the numba kernels as on a fresh clone (an empty
``NUMBA_CACHE_DIR``).

Measured in one session (2 cores, load average 7-19 from other jobs, numba cold),
before -> after the cuts (the real video's first 10 s, a 2-pair grid on 2 workers
started after the plan stage, the robot video 480x360 at 12 fps): 94.9 s -> 50.9 s
CPU, 978 s -> 556 s wall under that load. Per stage, before / after [s wall, loaded]:
capture 106 / 99, learn 33 / 57, plan 46 / 43, control_video 34 / 20, video 78 / 129,
control 271 / 375, generalize 553 / 278 (the foreground stages' times grow with the
background work they now overlap). The quiet figure before the cuts was 70 s: at the
same wall/CPU ratio, about 38 s after.

Per-stage CPU, measured later (load average 21-22, warm numba cache, 667.6 s wall): capture
14.7 s, demos 1.5, learn 0.7, learn_figures 4.6, plan 3.1, control_video 4.4 (one 10 s
simulation in-process: ~0.44 s CPU per simulated second at 1 kHz), video 6.7, control 1.2 +
its 7 runs in workers (~31 s at that rate), generalize 0.4 + its 2 pairs in workers,
control_figures 1.5, export 2.2: about 90 s of CPU in all, so 2 cores need at least ~45 s.
A profile of one run: MuJoCo's mj_step is ~13 % of a tick, the rest is the Python control
loop (controller, model terms, clipping, safety checks).

After cutting the tick's overhead (same maths: ufunc clips, a Cholesky solve for the
null-space projection, reused task-space terms, cached MuJoCo views, the safety test on
floats) and tracking one hand in the capture stage, measured before -> after in one
session, alternating, numba cold (``--numba-cold``), load average 7-10 on 2 cores:
total 177.7 -> 146.9 s wall (0.83x), this process's CPU 51.0 -> 43.8 s; per stage, wall
[CPU]: capture 49.0 [15.8] -> 28.9 [10.8] s, control_video 11.8 [4.9] -> 5.4 [2.6] s,
control 110.2 -> 87.6 s wall (0.79x), generalize 96.2 -> 87.7 s wall (0.91x); the plan
stage (7.7-7.9 s CPU, numba compiling the DMP kernels) is unchanged. Per tick
(``benchmarks/bench_control.py``, same session): the 6 s closed-loop lift with NTSM-PD
2.22 -> 1.28 s CPU (0.58x), NTSM-PD-DOB 2.65 -> 1.58 s (0.60x), i.e. 0.44 -> 0.26 s of
CPU per simulated second for the demo's slowest law.

The planner's kernels compiled in the background ``kernels`` stage (beside capture, demos
and learn) instead of in the plan stage, ``--numba-cold``, alternating before / after, two
rounds, load average 13-17 on 2 cores: the plan stage 6.2, 6.0 -> 3.0, 2.8 s CPU and
70.1, 58.6 -> 52.3, 27.7 s wall; ``kernels`` 3.8, 3.7 s CPU in the background; the totals
(236.8, 354.8 -> 287.5, 223.0 s wall; 36.1, 36.3 -> 37.6, 37.4 s CPU) follow the load.
A later pair at load average 10.6-11 (after, then before): demos + learn + plan, the
critical path up to the simulations, 23.5 s after vs 28.3 s before (plan 11.5 s wall,
2.9 s CPU vs 22.3 s, 6.2 s CPU); totals 86.4 vs 121.9 s wall (the control study's
50.5 vs 84.2 s is most of that difference, load), 35.1 vs 37.1 s CPU.

Later measurements (the whole command timed from outside, per stage): demo_results.md.
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path


def _cpu() -> float:
    own, kids = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--numba-cold", action="store_true", help="compile numba kernels anew")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        if args.numba_cold:
            os.environ["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
        from dexlfd.apps.demo import DemoConfig, run_demo

        load0 = os.getloadavg()[0]
        out = Path(tmp) / "demo"
        out.mkdir()
        c0, t0 = _cpu(), time.perf_counter()
        result = run_demo(DemoConfig(), out, fresh=True)
        total, cpu = time.perf_counter() - t0, _cpu() - c0
        t1 = time.perf_counter()
        run_demo(DemoConfig(), out)
        resumed = time.perf_counter() - t1
    background = {"capture", "kernels", "video", "generalize", "learn_figures"}
    cpu_by_stage = result.summary.get("cpu_seconds", {})
    for stage, seconds in result.summary["seconds"].items():
        note = " (background)" if stage in background else ""
        cpu_s = cpu_by_stage.get(stage, float("nan"))
        print(f"{stage:>16}: {seconds:6.1f} s wall, {cpu_s:6.1f} s CPU{note}")
    print(f"load average {load0:.1f} -> {os.getloadavg()[0]:.1f}")
    print(f"           total: {total:6.1f} s wall (target < 40 s), {cpu:.1f} s CPU; "
          f"resumed rerun {resumed:.1f} s")  # fmt: skip


if __name__ == "__main__":
    main()
