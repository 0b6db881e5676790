"""``dexlfd synth``: write seeded synthetic pick-and-place demonstrations.

Examples
--------
    dexlfd synth -n 6 --seed 0 -o demos/
    dexlfd learn demos/demo_*.npz -o model.npz

The folder must not hold other demonstration files: ``demo_*.npz`` left from an earlier,
larger run (or a recording) would be learned together with the new ones.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._common import bounded_int, ensure_output_dir, seed
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io import load_demonstration, save_demonstration

logger = logging.getLogger(__name__)

MAX_DEMOS = 1000


HELP = "write synthetic pick-and-place demonstrations (labelled synthetic)"


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(name, help=HELP)
    p.add_argument(
        "-n", "--n-demos", type=bounded_int(1, MAX_DEMOS), default=6,
        help=f"number of demonstrations, 1..{MAX_DEMOS} (default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--seed", type=seed, default=0, help="random seed, 0..2**32-1 (default: %(default)s)"
    )
    p.add_argument(
        "-o", "--output", required=True,
        help="output folder (new, or holding only demo_NN.npz files of an earlier synth run)",
    )  # fmt: skip
    return p


def _check_folder(folder: Path, n: int) -> None:
    """Refuse a folder whose demo files would mix with, or be replaced by, the new ones."""
    if not folder.is_dir():
        return
    new = {f"demo_{i:02d}.npz" for i in range(n)}
    for path in sorted(folder.glob("demo_*.npz")):
        if path.name not in new:
            raise InvalidInput(
                f"-o/--output {folder}: holds {path.name}, which is not one of the "
                f"{n} demonstrations written now; `learn {folder}/demo_*.npz` would mix it "
                "in. Use an empty folder"
            )
        try:
            synthetic = load_demonstration(path).meta.get("source") == "synthetic"
        except InvalidFile:
            synthetic = False
        if not synthetic:
            raise InvalidInput(
                f"-o/--output {folder}: {path.name} is not a synthetic demonstration; "
                "refusing to replace it. Use an empty folder"
            )


def run(args: argparse.Namespace) -> int:
    """Generate and save the demonstrations."""
    _check_folder(Path(args.output), args.n_demos)
    out = ensure_output_dir(args.output)
    from dexlfd.datasets import pick_place_demonstrations

    demos = pick_place_demonstrations(args.n_demos, np.random.default_rng(args.seed))
    for i, demo in enumerate(demos):
        meta = {**demo.meta, "seed": args.seed, "index": i, "n_demos": args.n_demos}
        demo = dataclasses.replace(demo, meta=meta)
        path = save_demonstration(out / f"demo_{i:02d}.npz", demo)
        logger.info("wrote %s (%d samples, %.1f s)", path, demo.n_samples, demo.t[-1])
    return 0
