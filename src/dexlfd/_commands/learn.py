"""``dexlfd learn``: learn a motion with its uncertainty from demonstration files.

Examples
--------
    dexlfd learn demos/demo_*.npz -o model.npz
    dexlfd learn demos/*.npz -o model.npz --k 6 --window 10 --reference 4 --plot figures/
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._common import (
    ensure_output_dir,
    nonnegative_int,
    output_file,
    progress,
    tick_callback,
)
from dexlfd.errors import InvalidInput
from dexlfd.io import load_demonstration, save_model

logger = logging.getLogger(__name__)


def _reference(value: str) -> int | str:
    if value == "medoid":
        return value
    try:
        index = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected 'medoid' or a demonstration index, got {value!r}"
        ) from None
    if index < 0:
        raise argparse.ArgumentTypeError(f"index must be >= 0, got {index}")
    return index


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help="learn a mean motion and its covariance from demonstrations (DTW, GMM, GMR)",
        description="Mean filter -> DTW alignment -> GMM (EM) -> GMR, thesis Sec. 4.3.",
    )
    p.add_argument("demos", nargs="+", metavar="DEMO_FILE", help="demonstration .npz files")
    p.add_argument("-o", "--output", required=True, help="model file to write (.npz)")
    p.add_argument(
        "--k",
        type=int,
        default=None,
        help="Gaussian components K, >= 1 (default: chosen from 6-20 by the held-out "
        "demonstrations' distance from the GMR mean; the thesis used 6)",
    )
    p.add_argument(
        "--window", type=int, default=10, help="mean-filter window in samples (default: 10)"
    )
    p.add_argument(
        "--reference",
        type=_reference,
        default="medoid",
        help="DTW reference: 'medoid' (default) or the index of a demonstration (0-based, "
        "in the order given)",
    )
    p.add_argument(
        "--exclude-outliers",
        action="store_true",
        help="leave demonstrations flagged as outliers (robust z > 3.5) out of the GMM",
    )
    p.add_argument(
        "--band-fraction",
        type=float,
        default=None,
        help="Sakoe-Chiba band radius for DTW as a fraction of the longer demo (default: none)",
    )
    p.add_argument(
        "--max-gap-s",
        type=float,
        default=0.5,
        help="longest run of invalid frames to interpolate [s] (default: %(default)s)",
    )
    p.add_argument(
        "--n-query", type=int, default=None, help="GMR time samples (default: the reference's)"
    )
    p.add_argument(
        "--seed", type=nonnegative_int, default=0, help="seed of the GMM initialisation (>= 0)"
    )
    p.add_argument("--plot", metavar="DIR", default=None, help="write learning figures to DIR")
    return p


def run(args: argparse.Namespace) -> int:
    """Load the demonstrations, learn, save the model (and figures)."""
    from dexlfd.learn import LearnConfig, learn_from_demonstrations

    out = Path(args.output)
    if out.suffix != ".npz":
        raise InvalidInput(f"-o/--output: model file must end in .npz, got {out}")
    output_file(out, "-o/--output")
    if args.plot:
        ensure_output_dir(args.plot, "--plot")  # fail now, not after learning
    cfg = LearnConfig(
        n_components="auto" if args.k is None else args.k,
        window=args.window,
        reference=args.reference,
        exclude_outliers=args.exclude_outliers,
        band_fraction=args.band_fraction,
        max_gap_s=args.max_gap_s,
        n_query=args.n_query,
    )
    logger.info("learn settings: %s", cfg)
    demos = [load_demonstration(path) for path in args.demos]
    names = [str(p) for p in args.demos]
    with progress(cfg.gmm_max_iter, "EM", quiet=args.quiet) as bar:
        result = learn_from_demonstrations(
            demos, cfg, np.random.default_rng(args.seed), tick_callback(bar), names=names
        )
    save_model(out, result.model)
    q = result.trajectory.quality
    for name, dist, z, flag in zip(names, q.distances, q.robust_z, q.outlier, strict=True):
        logger.info(
            "  %s: DTW distance %.4f, robust z %.2f%s", name, dist, z, "  OUTLIER" if flag else ""
        )
    logger.info(
        "wrote %s (%d samples, %.2f s, reference %s)",
        out,
        result.model.n_samples,
        result.model.t[-1],
        names[result.trajectory.alignment.reference_index],
    )
    if args.plot:
        from dexlfd.viz.learning import plot_learning

        folder = ensure_output_dir(args.plot, "--plot")
        for path in plot_learning(result, folder):
            logger.info("wrote %s", path)
    return 0
