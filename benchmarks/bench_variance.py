"""Variance term in metres vs relative: two demonstration sets over one box.

Two learned models with the same mean (the synthetic pick-and-place reference) whose
demonstrations agree to 1 mm or disagree by 3 cm (positional std), one 6 x 3 cm box
whose top is 3 cm above the carry (phase 0.55); the shaped coupling with the variance
measured in metres (default) and against the model's own 90th percentile (relative).
Prints the variance level, the push's displacement, how far beyond the needed lift it
goes and the clearance kept.

    python benchmarks/bench_variance.py
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from plan.test_variance_metres import _pair  # noqa: E402  (the test's fixture, not a copy)


def main() -> None:
    print(f"{'measure':<9} {'demos':>14} {'level':>6} {'displacement':>13} {'beyond':>8} "
          f"{'clearance':>10}")  # fmt: skip
    for measure in ("metres", "relative"):
        for sigma, r in _pair(measure).items():
            label = f"agree {1e3 * sigma:.0f} mm" if sigma < 0.01 else f"+-{1e2 * sigma:.0f} cm"
            beyond = 1e3 * (r["displacement"] - r["required_lift"])
            print(
                f"{measure:<9} {label:>14} {r['variance_level']:>6.2f} "
                f"{r['displacement']:>11.4f} m {beyond:>5.1f} mm {r['min_clearance']:>8.4f} m"
            )


if __name__ == "__main__":
    main()
