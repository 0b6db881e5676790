"""``dexlfd synth``: write seeded synthetic pick-and-place demonstrations."""

from __future__ import annotations

import argparse
import logging
from typing import Any

import numpy as np

from dexlfd._commands._common import ensure_output_dir, nonnegative_int, positive_int
from dexlfd.datasets import pick_place_demonstrations
from dexlfd.errors import InvalidInput
from dexlfd.io import save_demonstration

logger = logging.getLogger(__name__)

MAX_DEMOS = 1000


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name, help="write synthetic pick-and-place demonstrations (labelled synthetic)"
    )
    p.add_argument(
        "-n", "--n-demos", type=positive_int, default=6, help="number of demonstrations (1..1000)"
    )
    p.add_argument("--seed", type=nonnegative_int, default=0, help="random seed (>= 0)")
    p.add_argument("-o", "--output", required=True, help="output folder")
    return p


def run(args: argparse.Namespace) -> int:
    """Generate and save the demonstrations."""
    if args.n_demos > MAX_DEMOS:
        raise InvalidInput(f"-n/--n-demos: at most {MAX_DEMOS}, got {args.n_demos}")
    out = ensure_output_dir(args.output)
    demos = pick_place_demonstrations(args.n_demos, np.random.default_rng(args.seed))
    for i, demo in enumerate(demos):
        path = save_demonstration(out / f"demo_{i:02d}.npz", demo)
        logger.info("wrote %s (%d samples, %.1f s)", path, demo.n_samples, demo.t[-1])
    return 0
