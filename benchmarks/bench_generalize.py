"""Pick-and-place generalisation over the table on the demo's learned model.

Learns the demo's model (its demonstrations and learn settings, seed 0), then runs
``experiment generalize``'s study: ``--pairs`` pick/place pairs over two 30 x 40 cm
areas, each planned (time-scaled as ``dexlfd plan`` does), simulated with NTSM-PD at
0 kg (a 10 g box) and 1.2 kg, and scored (carried, within 2 cm, upright, set down
< 0.1 m/s). Prints the table, the plans' pose errors at the events and the time
scaling, and writes the figure to ``--out`` (default ``bench-generalize/``).

    python benchmarks/bench_generalize.py [--pairs 25] [--workers 2] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def demo_model():  # type: ignore[no-untyped-def]
    """The demo's own learned model (as the demo learns it, without a real video)."""
    from dexlfd.apps.demo import DemoConfig
    from dexlfd.datasets import demonstration_with_hand, pick_place_demonstrations
    from dexlfd.learn import learn_from_demonstrations

    cfg = DemoConfig(real_video=None)
    rng = np.random.default_rng([cfg.seed, 0])
    demos = [demonstration_with_hand(d, rng) for d in pick_place_demonstrations(cfg.n_demos, rng)]
    return learn_from_demonstrations(demos, cfg.learn, np.random.default_rng([cfg.seed, 1])).model


def main() -> None:
    from dexlfd.experiments.generalize import (
        GeneralizeConfig,
        format_generalize,
        generalize_json,
        run_generalize,
    )
    from dexlfd.viz.control import plot_generalize

    ap = argparse.ArgumentParser()
    ap.add_argument("--pairs", type=int, default=25)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--controllers", default="ntsm-pd")
    ap.add_argument("--out", default="bench-generalize")
    args = ap.parse_args()
    model = demo_model()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cfg = GeneralizeConfig(
        n_pairs=args.pairs, workers=args.workers, controllers=tuple(args.controllers.split(","))
    )
    t0 = time.perf_counter()
    result = run_generalize(model, cfg, quiet=True)
    print(format_generalize(result))
    print(f"{args.pairs} pairs x {len(cfg.payloads)} payloads in {time.perf_counter() - t0:.0f} s")
    (out / "generalize.json").write_text(json.dumps(generalize_json(result), default=str))
    print("figure:", plot_generalize(result, out / "generalize.png"))


if __name__ == "__main__":
    main()
