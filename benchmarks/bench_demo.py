"""Wall time of `dexlfd demo` per stage (fresh run, 2 workers), target <= 2 min in all."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from dexlfd.experiments.demo import DemoConfig, run_demo


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = run_demo(DemoConfig(), Path(tmp), fresh=True)
        total = time.perf_counter() - t0
        t1 = time.perf_counter()
        run_demo(DemoConfig(), Path(tmp))
        resumed = time.perf_counter() - t1
    for stage, seconds in result.summary["seconds"].items():
        print(f"{stage:>8}: {seconds:6.1f} s")
    print(f"   total: {total:6.1f} s (target <= 120 s); resumed rerun {resumed:.1f} s")


if __name__ == "__main__":
    main()
