"""``dexlfd demo``: the whole pipeline on bundled data, no camera.

Examples
--------
    dexlfd demo                 # outputs in dexlfd-demo/, report.html first
    dexlfd demo -o out/ --fresh # ignore finished stages of an earlier run
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path
from typing import Any

from dexlfd._commands._common import bounded_int, seed

logger = logging.getLogger(__name__)

SOFTHAND_PAYLOAD_KG = 0.3  # [kg] the demo's object with the softhand
MAX_WORKERS = 64  # processes; each simulation holds a MuJoCo model (~100 MB)


HELP = "run the whole pipeline on bundled data and write an HTML report"


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(name, help=HELP)
    p.add_argument(
        "-o", "--output", default="dexlfd-demo", help="output folder (default: %(default)s)"
    )
    p.add_argument(
        "--seed", type=seed, default=0, help="random seed, 0..2**32-1 (default: %(default)s)"
    )
    p.add_argument(
        "--fresh", action="store_true", help="rerun every stage (default: resume finished ones)"
    )
    p.add_argument(
        "--overwrite", action="store_true",
        help="write into an OUTPUT folder that holds files but no earlier demo's manifest",
    )  # fmt: skip
    p.add_argument(
        "--workers", type=bounded_int(1, MAX_WORKERS), default=2,
        help=f"processes for the simulations, 1..{MAX_WORKERS} (default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--hand", choices=["franka", "softhand"], default="franka", dest="end_effector",
        help="end-effector: the Franka Hand with a 1.2 kg object, or the simulated qb "
        "SoftHand (3 N grasp) with a 0.3 kg one (default: franka)",
    )  # fmt: skip
    p.add_argument(
        "--no-real-video", action="store_true", help="skip the capture stage on the real hand video"
    )
    p.add_argument(
        "--rerun",
        metavar="FILE.rrd",
        help="also write a rerun recording of the run: demonstrations, real video with the "
        "tracked hand, plan with the model's 2-sigma tube, cup, robot TCP path",
    )
    return p


def run(args: argparse.Namespace) -> int:
    """Run the demo pipeline."""
    import dataclasses

    from dexlfd._commands._outputs import DIR, check_outputs
    from dexlfd.apps.demo import DemoConfig, run_demo

    out, _ = check_outputs([("-o/--output", args.output, DIR), ("--rerun", args.rerun, ".rrd")])
    assert out is not None  # -o is required
    _check_demo_folder(out, args.overwrite)
    cfg = DemoConfig(seed=args.seed, workers=args.workers)
    if args.end_effector == "softhand":  # its 3 N squeeze holds ~0.5 kg by friction, not 1.2 kg
        cfg = dataclasses.replace(cfg, hand="softhand", payload_kg=SOFTHAND_PAYLOAD_KG)
    if args.no_real_video:
        cfg = dataclasses.replace(cfg, real_video=None)
    t0 = time.perf_counter()
    result = run_demo(cfg, out, fresh=args.fresh)
    logger.info("demo finished in %.1f s; stage times %s", time.perf_counter() - t0,
                result.summary["seconds"])  # fmt: skip
    sys.stdout.write(f"report: {result.summary['report']}\n")
    if args.rerun:
        from dexlfd.apps.demo import write_demo_rerun

        sys.stdout.write(f"rerun: {write_demo_rerun(cfg, out, args.rerun)}\n")
    return 0


def _check_demo_folder(out: Path, overwrite: bool) -> None:
    """Refuse a folder of someone's files: the demo writes model.npz, report.html, ... there."""
    from dexlfd.apps._stages import MANIFEST
    from dexlfd.errors import InvalidInput

    if overwrite or (out / MANIFEST).is_file():
        return
    theirs = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    if theirs:
        raise InvalidInput(
            f"-o/--output {out}: holds {', '.join(theirs[:3])}{' ...' if len(theirs) > 3 else ''}"
            " but no earlier demo's manifest; the demo would replace files of the same names "
            "(--overwrite writes there anyway, or use a new folder)"
        )
