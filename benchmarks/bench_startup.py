"""Start-up time of the command line: ``import dexlfd``, ``dexlfd --help``, ``dexlfd CMD --help``.

Each figure is the median (and min..max) of fresh interpreters, so imports are counted
as a user meets them, as wall time and as the interpreter's CPU time (user + system; on a
machine shared with other jobs the CPU time varies less). ``dexlfd --help`` builds the
one-line summaries only; a command's ``--help`` builds that command's flags (and imports
what their ranges come from).

    python benchmarks/bench_startup.py [--runs N]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import time

COMMANDS = (
    "demo", "teach", "learn", "synth", "export", "plan", "simulate", "experiment", "record",
    "teleop", "calibrate",
)  # fmt: skip
CASES = {
    "import dexlfd": ["-c", "import dexlfd"],
    "dexlfd --help": ["-m", "dexlfd", "--help"],
    **{f"dexlfd {c} --help": ["-m", "dexlfd", c, "--help"] for c in COMMANDS},
    "python (no dexlfd)": ["-c", "pass"],
}


def timed(args: list[str]) -> tuple[float, float]:
    """Wall and CPU time [s] of one fresh interpreter running ``args``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, *args], check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--only", nargs="*", help="the cases whose name contains one of these")
    opts = parser.parse_args()
    runs = opts.runs
    for name, args in CASES.items():
        if opts.only and not any(word in name for word in opts.only):
            continue
        timed(args)  # warm the file cache
        walls, cpus = zip(*(timed(args) for _ in range(runs)), strict=True)
        print(f"{name:28s} wall median {statistics.median(walls):.3f} s "
              f"({min(walls):.3f}..{max(walls):.3f}), CPU median {statistics.median(cpus):.3f} s "
              f"({min(cpus):.3f}..{max(cpus):.3f}), {runs} runs")  # fmt: skip


if __name__ == "__main__":
    main()
