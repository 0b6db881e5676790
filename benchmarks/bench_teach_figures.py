"""CPU of ``teach``'s four figures, each drawn once in a fresh process as its stage does.

A teach run's folder (``dexlfd teach CLIP -o OUT``) gives the data; each figure is drawn
by the function its stage calls, in a forked child of a process that has loaded what
``teach``'s process has by then (the warm-up's modules and ``matplotlib.pyplot``, which
MediaPipe loads), so the child's first drawing pays what the stage's does.

    PYTHONPATH=src python benchmarks/bench_teach_figures.py OUT --rounds 6 --compare OTHER/src

``--compare``: the same in a process of the code under ``OTHER/src``, interleaved, and
each figure's CPU as a ratio (this / other) per round. Results: ``teach_results.md``.
"""

from __future__ import annotations

import argparse
import importlib
import json
import multiprocessing
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

FIGURES = ("demos", "model", "plan", "tracking")


def _draw(name: str, run: Path, folder: Path) -> float:
    """Draw figure ``name`` of the teach run ``run`` into ``folder``; its CPU seconds."""
    from dexlfd.apps import teach_figures
    from dexlfd.apps.teach import TeachConfig
    from dexlfd.io import load_model, load_plan, load_rollout
    from dexlfd.viz.control import plot_rollout
    from dexlfd.viz.demonstrations import plot_demonstrations
    from dexlfd.viz.learning import plot_gmr
    from dexlfd.viz.teach import plot_task_plan

    t0 = time.process_time()
    summary = json.loads((run / "manifest.json").read_text())["frame"]["summary"]
    if name == "tracking":
        plot_rollout(load_rollout(run / "rollout.npz"), folder / "rollout.png")
    elif name == "plan":
        size = tuple(float(v) for v in summary["placement"]["object_size"])
        plot_task_plan(load_model(run / "model.npz"), load_plan(run / "plan.npz"), size,
                       folder / "plan.png")  # fmt: skip
    else:  # learned as the figures stage does, not counted
        cfg = TeachConfig(sources=())
        learned, demos = teach_figures.learn_demonstrations(cfg, run, summary["demonstrations"])
        t0 = time.process_time()
        if name == "demos":
            moved = teach_figures.task_frame_demos(demos, summary["task_to_base"])
            plot_demonstrations(moved, folder / "demos_task.png")
        else:
            plot_gmr(learned.trajectory, folder / "model.png")
    return time.process_time() - t0


def _child(name: str, run: Path, folder: Path) -> None:  # pragma: no cover - in the child
    print(json.dumps({"figure": name, "cpu_s": _draw(name, run, folder)}), flush=True)


def measure(run: Path) -> None:
    """Each figure drawn once in a forked child; one JSON line each."""
    from dexlfd.apps.teach_warm import WARM_MODULES

    for module in (*WARM_MODULES, "matplotlib.pyplot"):
        importlib.import_module(module)
    ctx = multiprocessing.get_context("fork")
    with tempfile.TemporaryDirectory() as tmp:
        for name in FIGURES:
            proc = ctx.Process(target=_child, args=(name, run, Path(tmp)))
            proc.start()
            proc.join()


def _side(src: str | None, run: Path) -> dict[str, float]:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = src
    out = subprocess.run([sys.executable, __file__, str(run), "--measure"], env=env,
                         capture_output=True, text=True, check=True).stdout  # fmt: skip
    rows = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    return {r["figure"]: r["cpu_s"] for r in rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path, help="a teach run's folder")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--compare", help="the other code's src folder (interleaved)")
    ap.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.measure:
        measure(args.run)
        return
    this: dict[str, list[float]] = {n: [] for n in FIGURES}
    other: dict[str, list[float]] = {n: [] for n in FIGURES}
    for _ in range(args.rounds):
        for side, src in ((other, args.compare), (this, None)):
            if side is other and src is None:
                continue
            for name, cpu in _side(src, args.run).items():
                side[name].append(cpu)
    for name in FIGURES:
        line: dict[str, Any] = {"figure": name, "cpu_s": round(statistics.median(this[name]), 3)}
        if args.compare:
            ratios = [a / b for a, b in zip(this[name], other[name], strict=True)]
            line |= {"other_cpu_s": round(statistics.median(other[name]), 3),
                     "ratio_median": round(statistics.median(ratios), 2),
                     "ratios": [round(r, 2) for r in ratios]}  # fmt: skip
        print(json.dumps(line))


if __name__ == "__main__":
    main()
