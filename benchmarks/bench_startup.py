"""Start-up time of the command line: ``import dexlfd``, ``dexlfd --help``, ``dexlfd CMD --help``.

Each figure is the median (and min..max) of fresh interpreters, so imports are counted
as a user meets them. ``dexlfd --help`` builds the one-line summaries only; a command's
``--help`` builds that command's flags (and imports what their ranges come from).

    python benchmarks/bench_startup.py [--runs N]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

CASES = {
    "import dexlfd": ["-c", "import dexlfd"],
    "dexlfd --help": ["-m", "dexlfd", "--help"],
    "dexlfd learn --help": ["-m", "dexlfd", "learn", "--help"],
    "dexlfd plan --help": ["-m", "dexlfd", "plan", "--help"],
    "dexlfd record --help": ["-m", "dexlfd", "record", "--help"],
    "python (no dexlfd)": ["-c", "pass"],
}


def wall(args: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, *args], check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    runs = parser.parse_args().runs
    for name, args in CASES.items():
        wall(args)  # warm the file cache
        times = [wall(args) for _ in range(runs)]
        print(f"{name:22s} median {statistics.median(times):.3f} s "
              f"({min(times):.3f}..{max(times):.3f}, {runs} runs)")  # fmt: skip


if __name__ == "__main__":
    main()
