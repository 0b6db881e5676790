"""Wall time of `dexlfd demo` per stage (fresh run, 2 workers), target <= 35 s in all.

``capture`` and ``video`` run in background processes (their times overlap the
others'), so the total is less than the sum of the stages. On a busy machine
compare the stages as ratios of one run; the load average is printed.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from dexlfd.apps.demo import DemoConfig, run_demo


def main() -> None:
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = run_demo(DemoConfig(), Path(tmp), fresh=True)
        total = time.perf_counter() - t0
        t1 = time.perf_counter()
        run_demo(DemoConfig(), Path(tmp))
        resumed = time.perf_counter() - t1
    background = {"capture", "video"}
    for stage, seconds in result.summary["seconds"].items():
        note = " (background)" if stage in background else ""
        print(f"{stage:>16}: {seconds:6.1f} s{note}")
    fg = sum(s for k, s in result.summary["seconds"].items() if k not in background)
    print(f"foreground stages: {fg:.1f} s; load average {load0:.1f} -> {os.getloadavg()[0]:.1f}")
    print(f"           total: {total:6.1f} s (target <= 35 s); resumed rerun {resumed:.1f} s")


if __name__ == "__main__":
    main()
