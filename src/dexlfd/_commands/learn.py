"""``dexlfd learn``: learn a motion with its uncertainty from demonstration files.

Examples
--------
    dexlfd learn demos/demo_*.npz -o model.npz
    dexlfd learn demos/*.npz -o model.npz --k 6 --window 10 --reference 4 --plot figures/
"""

from __future__ import annotations

import argparse
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._common import (
    bounded_float,
    bounded_int,
    ensure_output_dir,
    progress,
    seed,
    tick_callback,
)
from dexlfd._commands._outputs import DIR, check_outputs
from dexlfd.errors import InvalidInput
from dexlfd.io import load_demonstration, save_model

logger = logging.getLogger(__name__)

MAX_K = 50  # Gaussians: EM's cost grows with K; a demo has a handful of motion phases
MAX_WINDOW = 10_000  # [samples]; learning also refuses a window over half a demonstration
MAX_QUERY = 100_000  # GMR time samples (the model stores an 8x8 covariance per sample)
# library parameter -> flag, for errors (cli.speak_cli)
FLAGS = {
    "n_components": "--k",
    "window": "--window",
    "reference index": "--reference",
    "reference": "--reference",
    "band_fraction": "--band-fraction",
    "max_gap_s": "--max-gap-s",
    "n_query": "--n-query",
}


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


HELP = "learn a mean motion and its covariance from demonstrations (DTW, GMM, GMR)"


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    from dexlfd.learn.dtw import MAX_CELLS as MAX_DTW_CELLS

    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help=HELP,
        description="Mean filter -> DTW alignment -> GMM (EM) -> GMR, thesis Sec. 4.3.",
    )
    p.add_argument(
        "demos",
        nargs="+",
        metavar="DEMO",
        help="demonstration .npz files, or LeRobot v3.0 dataset folders of demonstrations "
        "(as `dexlfd export --format lerobot` writes them; one demonstration per episode)",
    )
    p.add_argument("-o", "--output", required=True, help="model file to write (.npz)")
    p.add_argument(
        "--k", type=bounded_int(1, MAX_K), default=None,
        help=f"Gaussian components K, 1..{MAX_K} (default: chosen from 6-20 by the held-out "
        "demonstrations' distance from the GMR mean; the thesis used 6)",
    )  # fmt: skip
    p.add_argument(
        "--window", type=bounded_int(1, MAX_WINDOW), default=None,
        help="mean-filter window [samples], 1..half the shortest demonstration; 1 = no filter "
        "(default: the thesis's 10 where it lowers Stein's risk estimate of the "
        "demonstrations, i.e. they carry noise to remove, else 1)",
    )  # fmt: skip
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
        type=bounded_float(0.0, 1.0, lo_open=True),
        default=None,
        help="Sakoe-Chiba band radius for DTW as a fraction of the longer demo, (0, 1] "
        f"(default: none); a DTW grid holds at most {MAX_DTW_CELLS:.0e} cells (two demos of "
        f"{math.isqrt(MAX_DTW_CELLS)} samples without a band), a narrower band aligns longer "
        "demos",
    )
    p.add_argument(
        "--max-gap-s",
        type=bounded_float(0.0, 60.0),
        default=0.5,
        help="longest run of invalid frames to interpolate [s], 0..60 (default: %(default)s)",
    )
    p.add_argument(
        "--n-query", type=bounded_int(2, MAX_QUERY), default=None,
        help=f"GMR time samples, 2..{MAX_QUERY} (default: the reference's)",
    )  # fmt: skip
    p.add_argument(
        "--seed", type=seed, default=0,
        help="seed of the GMM initialisation, 0..2**32-1 (default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--plot", metavar="DIR", default=None, help="write learning figures (PNG) to folder DIR"
    )
    return p


def _load_demos(paths: list[str]) -> tuple[list[Any], list[str]]:
    """Demonstration files and LeRobot dataset folders -> demonstrations and their names."""
    from dexlfd.io.lerobot import import_lerobot, is_lerobot_dataset

    demos: list[Any] = []
    names: list[str] = []
    for path in paths:
        if Path(path).is_dir():
            if not is_lerobot_dataset(path):
                raise InvalidInput(f"{path}: a folder must be a LeRobot dataset (meta/info.json)")
            dataset = import_lerobot(path)
            demos += dataset.records
            names += [f"{path}#episode{i}" for i in range(len(dataset.records))]
        else:
            demos.append(load_demonstration(path))
            names.append(str(path))
    return demos, names


def run(args: argparse.Namespace) -> int:
    """Load the demonstrations, learn, save the model (and figures)."""
    from dexlfd.learn import LearnConfig, learn_from_demonstrations
    from dexlfd.learn.quality import MIN_DEMOS_FOR_OUTLIERS

    check_outputs(
        [("-o/--output", args.output, ".npz"), ("--plot", args.plot, DIR)], inputs=args.demos
    )
    out = Path(args.output)
    cfg = LearnConfig(
        n_components="auto" if args.k is None else args.k,
        window="auto" if args.window is None else args.window,
        reference=args.reference,
        exclude_outliers=args.exclude_outliers,
        band_fraction=args.band_fraction,
        max_gap_s=args.max_gap_s,
        n_query=args.n_query,
    )
    logger.debug("learn settings: %s", cfg)
    demos, names = _load_demos(args.demos)
    with progress(cfg.gmm_max_iter, "EM", quiet=args.quiet) as bar:
        result = learn_from_demonstrations(
            demos, cfg, np.random.default_rng(args.seed), tick_callback(bar), names=names
        )
    save_model(out, result.model)
    q = result.trajectory.quality
    tested = len(names) >= MIN_DEMOS_FOR_OUTLIERS  # else every z is 0 by construction
    for name, dist, z, flag in zip(names, q.distances, q.robust_z, q.outlier, strict=True):
        logger.info(
            "  %s: DTW distance %.4f%s%s", name, dist, f", robust z {z:.2f}" if tested else "",
            "  OUTLIER" if flag else "",
        )  # fmt: skip
    if q.note:
        logger.warning("outlier test: %s", q.note)
    _log_events(result.model)
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


def _log_events(model: Any) -> None:
    """One line per grasp event the model carries (pick and place, with their spread)."""
    if not model.has_events:
        found = model.grasp_events
        note = (found.note if found is not None else None) or "no grasp events"
        logger.warning("grasp events: %s; plans are one motion (no --pick/--place)", note)
        return
    std = np.sqrt(np.diagonal(model.event_cov, axis1=1, axis2=2))
    for k, name in enumerate(("pick (the hand closes)", "place (the hand opens)")):
        logger.info(
            "  %s at t = %.2f s (std %.2f s) at %s m (std %.1f mm, %.1f deg), %d demonstrations",
            name, model.event_t[k], model.event_t_std[k],
            np.round(model.event_position[k], 3).tolist(), 1e3 * float(np.linalg.norm(std[k, :3])),
            float(np.degrees(np.linalg.norm(std[k, 3:]))), int(model.event_count[k]),
        )  # fmt: skip
