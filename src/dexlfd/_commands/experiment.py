"""``dexlfd experiment``: reproducible studies.

Examples
--------
    dexlfd experiment payload -o results/ --json table.json
    dexlfd experiment payload --workers 2 --duration-s 6
    dexlfd experiment payload --robot franky-sim -o study-franka/   # over the Franka protocol
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from typing import Any

from dexlfd._commands._common import (
    bounded_float,
    bounded_int,
    ensure_output_dir,
    progress,
    seed,
    tick_callback,
)
from dexlfd._commands._outputs import DIR, check_outputs

logger = logging.getLogger(__name__)

MAX_WORKERS = 64  # processes; each simulation holds a MuJoCo model (~100 MB)
MAX_DURATION_S = 60.0  # [s] of the stand-in lift; every run simulates it at 1 kHz
# library parameter -> flag, for errors (cli.speak_cli)
FLAGS = {
    "workers": "--workers",
    "model_error": "--model-error",
    "model error": "--model-error",
    "duration": "--duration-s",
    "lockstep_s": "--sim-lockstep-s",
}


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name, help="run a study (payload: Table 5.1 with an unknown payload)"
    )
    p.add_argument("study", choices=["payload"], help="which study")
    p.add_argument(
        "-o", "--output", default="payload-study", help="folder for figures (default: %(default)s)"
    )
    p.add_argument("--json", help="write the table rows as JSON to this file (.json)")
    p.add_argument(
        "--controllers", default=None,
        help="comma-separated registry names (default: pd,sm-pd,ntsm-pd,ntsm-pd-i,ntsm-pd-dob)",
    )  # fmt: skip
    p.add_argument(
        "--plan", default=None,
        help="plan .npz to track (e.g. from `dexlfd plan` with an obstacle; its boxes are "
        "put in the scene); default: a stand-in 6 s lift over a box",
    )  # fmt: skip
    p.add_argument(
        "--duration-s", type=bounded_float(0.0, MAX_DURATION_S, lo_open=True), default=6.0,
        help=f"stand-in lift duration [s], (0, {MAX_DURATION_S:g}] (default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--model-error", type=bounded_float(0.0, 0.99), default=0.1,
        help="relative mass/inertia error of the controllers' model, 0..0.99 "
        "(default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--workers", type=bounded_int(1, MAX_WORKERS), default=2,
        help=f"processes, 1..{MAX_WORKERS} (1 = sequential; default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--seed", type=seed, default=0, help="random seed, 0..2**32-1 (default: %(default)s)"
    )
    p.add_argument(
        "--robot", choices=["mujoco", "franky-sim"], default="mujoco",
        help="franky-sim: run the study over the Franka protocol (pylibfranka) on franky-sim",
    )  # fmt: skip
    p.add_argument("--sim-root", default=".venv-franka-sim", help="franky-sim's venv cache")
    p.add_argument(
        "--sim-lockstep-s", type=bounded_float(0.0, 600.0, lo_open=True), default=None,
        help="run franky-sim in lock-step with the controller: each cycle waits up to this "
        "long for its command [s], (0, 600] (default: real time, as a robot)",
    )  # fmt: skip
    return p


def run(args: argparse.Namespace) -> int:
    """Run the study, print the table, write figures and JSON."""
    check_outputs(
        [("-o/--output", args.output, DIR), ("--json", args.json, ".json")], inputs=[args.plan]
    )  # fail now, not after the study
    if args.robot == "franky-sim":
        from dexlfd._commands._franka import run_protocol_study

        return run_protocol_study(args)
    from dexlfd.experiments.payload import (
        PayloadConfig,
        format_table,
        rows_as_json,
        run_payload_experiment,
    )
    from dexlfd.io import atomic_write
    from dexlfd.viz.control import plot_payload_lift

    out = ensure_output_dir(args.output)
    kwargs: dict[str, Any] = {
        "duration": args.duration_s, "model_error": args.model_error,
        "workers": args.workers, "seed": args.seed,
    }  # fmt: skip
    if args.plan:
        from dexlfd.io import load_plan
        from dexlfd.robot import obstacles_from_plan_meta

        plan = load_plan(args.plan)
        kwargs["plan"] = plan
        kwargs["obstacles"] = obstacles_from_plan_meta(plan.meta)
    if args.controllers:
        kwargs["controllers"] = tuple(c.strip() for c in args.controllers.split(",") if c.strip())
    cfg = PayloadConfig(**kwargs)
    n = len(cfg.controllers) * len(cfg.payloads)
    with progress(n, "payload study", quiet=args.quiet) as bar:
        result = run_payload_experiment(cfg, callback=tick_callback(bar))
    sys.stdout.write(format_table(result) + "\n")
    fig = plot_payload_lift(result, out / "payload_lift_z.png")
    logger.info("wrote %s", fig)
    if args.json:
        from pathlib import Path

        text = json.dumps(rows_as_json(result.rows), indent=2)
        atomic_write(Path(args.json), lambda fh: fh.write(text.encode()))
        logger.info("wrote %s", args.json)
    return 0
