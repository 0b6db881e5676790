"""``dexlfd learn``: learn a motion with its uncertainty from demonstration files.

Examples
--------
    dexlfd learn demos/ -o model.npz
    dexlfd learn demos/*.npz -o model.npz --k 6 --window 10 --reference 4 --plot figures/
"""

from __future__ import annotations

import argparse
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._common import ensure_output_dir, progress, seed, tick_callback
from dexlfd._commands._fields import add_params
from dexlfd._commands._outputs import DIR, check_outputs
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
        help="demonstration .npz files, folders of them (as `dexlfd synth` and `dexlfd record` "
        "write them: every .npz inside), or LeRobot v3.0 dataset folders of demonstrations "
        "(as `dexlfd export --format lerobot` writes them; one demonstration per episode)",
    )
    p.add_argument("-o", "--output", required=True, help="model file to write (.npz)")
    from dexlfd.learn import LearnConfig

    dtw = (
        f"a DTW grid holds at most {MAX_DTW_CELLS:.0e} cells (two demos of "
        f"{math.isqrt(MAX_DTW_CELLS)} samples without a band)"
    )
    add_params(p, LearnConfig, ["n_components", "window"])
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
    add_params(
        p, LearnConfig, ["band_fraction", "max_gap_s", "n_query"], notes={"band_fraction": dtw}
    )
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
        if Path(path).is_dir() and not is_lerobot_dataset(path):
            files = sorted(Path(path).glob("*.npz"))
            if not files:
                raise InvalidInput(
                    f"{path}: a folder must hold demonstration .npz files or be a LeRobot "
                    "dataset (meta/info.json)"
                )
            for file in files:
                demos.append(load_demonstration(file))
                names.append(str(file))
        elif Path(path).is_dir():
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
        n_components=args.k,
        window=args.window,
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
        with progress(None, "figures", quiet=args.quiet) as bar:
            plot_learning(result, folder, callback=lambda path: _wrote(path, bar))
    return 0


def _wrote(path: Path, bar: Any) -> None:
    """One figure written: said, and counted on the bar."""
    logger.info("wrote %s", path)
    bar.update(1)


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
