"""CPU of ``teach``'s plan stage, rerun on finished ``teach`` folders (no video, no simulation).

For each folder given (``dexlfd teach SOURCE -o DIR`` run to the end: its
``model.npz`` and the frame stage's placement in ``manifest.json``), a fresh process
does what ``teach`` does before its plan stage (its warm-up: the stages' imports, the
numba kernels, :func:`dexlfd.plan.kernels.warm_kernels`), then runs the plan stage
(``apps.teach._stage_plan``: the plan, its time scaling, the plan file) ``--repeat``
times into a temporary folder. Printed per folder: the CPU seconds of the first run
(what ``teach`` pays: one plan a process) and the median of the later ones, and a
digest of the plan file (runs that agree byte for byte print the same digest).

``--compare SRC`` also runs another checkout's ``src`` folder (e.g. ``git archive
main``), process by process interleaved with this one's, ``--rounds`` times, and prints
the medians of both and their ratio. OpenBLAS on one thread, as the command line runs it.
Run with the venv's python::

    PYTHONPATH=src python benchmarks/bench_teach_plan.py DIR [DIR ...] [--repeat 5]
        [--rounds 3] [--compare OTHER/src]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def _child(folder: Path, repeat: int) -> None:
    """In this process: the warm-up, then the plan stage ``repeat`` times; one JSON line."""
    from dexlfd.apps.teach import TeachConfig, _stage_plan
    from dexlfd.apps.teach_warm import warm_up

    warm_up()
    frame = json.loads((folder / "manifest.json").read_text())["frame"]
    cpu: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        shutil.copy(folder / "model.npz", out / "model.npz")
        for _ in range(repeat):
            t0 = time.process_time()
            _stage_plan(TeachConfig(sources=(str(folder),)), out, frame)
            cpu.append(time.process_time() - t0)
        digest = hashlib.sha256((out / "plan.npz").read_bytes()).hexdigest()[:16]
    print(json.dumps({"cpu": cpu, "digest": digest}))


def _run(src: Path, folder: Path, repeat: int) -> dict[str, object]:
    env = {**os.environ, "PYTHONPATH": str(src), "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run(
        [sys.executable, __file__, "--child", str(folder), "--repeat", str(repeat)],
        env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", type=Path, help="finished teach output folders")
    ap.add_argument("--repeat", type=int, default=5, help="plan stages a process (default 5)")
    ap.add_argument("--rounds", type=int, default=3, help="processes a checkout (default 3)")
    ap.add_argument("--compare", type=Path, metavar="SRC", help="another checkout's src")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        _child(args.folders[0], args.repeat)
        return
    sides = {"this": SRC, **({"other": args.compare} if args.compare else {})}
    print(
        f"load average {os.getloadavg()[0]:.1f}; {args.rounds} processes a side, "
        f"{args.repeat} plan stages each; CPU s: first run (median), later runs (median)"
    )
    med = statistics.median
    for folder in args.folders:
        first: dict[str, list[float]] = {k: [] for k in sides}
        later: dict[str, list[float]] = {k: [] for k in sides}
        digests: dict[str, set[str]] = {k: set() for k in sides}
        for _ in range(args.rounds):
            for side, src in sides.items():
                res = _run(src, folder, args.repeat)
                cpu = list(res["cpu"])  # type: ignore[call-overload]
                first[side].append(cpu[0])
                later[side].extend(cpu[1:])
                digests[side].add(str(res["digest"]))
        line = [folder.name]
        for side in sides:
            plan = "/".join(sorted(digests[side]))
            line.append(
                f"{side}: first {med(first[side]):.3f} later {med(later[side]):.3f} plan {plan}"
            )
        if args.compare:
            r_first = med(first["this"]) / med(first["other"])
            r_later = med(later["this"]) / med(later["other"])
            line.append(f"this/other: first {r_first:.2f} later {r_later:.2f}")
        print("; ".join(line), flush=True)


if __name__ == "__main__":
    main()
