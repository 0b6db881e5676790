"""``dexlfd experiment``: reproducible studies.

Examples
--------
    dexlfd experiment payload -o results/ --json table.json
    dexlfd experiment payload --workers 2 --duration-s 6
    dexlfd experiment payload --robot franky-sim -o study-franka/   # over the Franka protocol
    dexlfd experiment payload --trials 64 --workers 2 -o mc/       # Monte-Carlo, 95 % intervals
    dexlfd experiment payload --trials 1000 --engine ray --ray-address head:6379
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path
from typing import Any

from dexlfd._commands._common import (
    bounded_float,
    bounded_int,
    ensure_output_dir,
    nonnegative_int,
    seed,
)
from dexlfd._commands._outputs import DIR, check_outputs

logger = logging.getLogger(__name__)

MAX_WORKERS = 64  # processes; each simulation holds a MuJoCo model (~100 MB)
MAX_DURATION_S = 60.0  # [s] of the stand-in lift; every run simulates it at 1 kHz
# library parameter -> flag, for errors (cli.speak_cli); the Monte-Carlo ranges are named
# with their class, as MonteCarloConfig's messages name them (model_error is in both)
FLAGS = {
    "workers": "--workers",
    "model_error": "--model-error",
    "model error": "--model-error",
    "duration": "--duration-s",
    "lockstep_s": "--sim-lockstep-s",
    "MonteCarloConfig.payload_kg": "--mc-payload-kg",
    "MonteCarloConfig.model_error": "--mc-model-error",
    "MonteCarloConfig.noise_scale": "--mc-noise-scale",
    "MonteCarloConfig.torque_delay": "--mc-delay-ticks",
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
        help=f"processes, or CPUs of the local Ray cluster, 1..{MAX_WORKERS} (1 = sequential; "
        "default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--engine", choices=["local", "ray"], default="local",
        help="local: this machine's process pool (default); ray: a local Ray cluster with "
        "--workers CPUs, or the cluster at --ray-address",
    )  # fmt: skip
    p.add_argument(
        "--ray-address", default=None,
        help="a running Ray cluster (host:6379, ray://host:10001 or auto) for --engine ray; "
        "its nodes need the same dexlfd installed",
    )  # fmt: skip
    mc = p.add_argument_group(
        "Monte-Carlo (--trials N > 0): every trial draws a plant uniformly from these ranges "
        "and runs every controller with and without the object; means and 95 % intervals"
    )
    mc.add_argument(
        "--trials", type=nonnegative_int, default=0,
        help="random plants (default 0: the Table 5.1 study on one plant)",
    )  # fmt: skip
    mc.add_argument("--mc-payload-kg", type=_range(float), default=(0.2, 1.5),
                    help="object mass LO,HI [kg], within 0..3 (default 0.2,1.5)")  # fmt: skip
    mc.add_argument("--mc-model-error", type=_range(float), default=(0.0, 0.2),
                    help="model mass/inertia error LO,HI [-], within 0..0.99 "
                    "(default 0,0.2)")  # fmt: skip
    mc.add_argument("--mc-noise-scale", type=_range(float), default=(0.0, 2.0),
                    help="factor LO,HI on the measurement noise (1e-5 rad, 1e-3 rad/s), >= 0 "
                    "(default 0,2)")  # fmt: skip
    mc.add_argument("--mc-delay-ticks", type=_range(int), default=(0, 2),
                    help="torque delay LO,HI [1 ms ticks], >= 0 (default 0,2)")  # fmt: skip
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


def _range(kind: type) -> Any:
    """Argparse type: ``LO,HI`` with LO <= HI."""

    def parse(text: str) -> tuple[Any, Any]:
        try:
            lo, hi = (kind(v) for v in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected LO,HI ({kind.__name__}s), got {text!r}"
            ) from None
        if not lo <= hi:
            raise argparse.ArgumentTypeError(f"expected LO <= HI, got {text!r}")
        return lo, hi

    return parse


def run(args: argparse.Namespace) -> int:
    """Run the study, print the table, write figures and JSON."""
    check_outputs(
        [("-o/--output", args.output, DIR), ("--json", args.json, ".json")], inputs=[args.plan]
    )  # fail now, not after the study
    if args.robot == "franky-sim":
        from dexlfd._commands._franka import run_protocol_study
        from dexlfd.errors import InvalidInput

        if args.trials or args.engine != "local":
            raise InvalidInput("--trials and --engine ray need --robot mujoco")

        return run_protocol_study(args)
    from dexlfd.experiments.payload import PayloadConfig

    out = ensure_output_dir(args.output)
    kwargs: dict[str, Any] = {
        "duration": args.duration_s, "model_error": args.model_error,
        "workers": args.workers, "seed": args.seed, "engine": args.engine,
        "ray_address": args.ray_address,
    }  # fmt: skip
    if args.plan:
        from dexlfd.io import load_plan
        from dexlfd.robot import plan_world

        plan = load_plan(args.plan)
        kwargs["plan"] = plan
        kwargs["obstacles"] = plan_world(plan)
    if args.controllers:
        kwargs["controllers"] = tuple(c.strip() for c in args.controllers.split(",") if c.strip())
    cfg = PayloadConfig(**kwargs)
    if args.trials:
        return _run_monte_carlo(args, cfg, out)
    from dexlfd.experiments.payload import format_table, rows_as_json, run_payload_experiment
    from dexlfd.io import atomic_write
    from dexlfd.viz.control import plot_payload_lift

    result = run_payload_experiment(cfg, quiet=args.quiet)
    sys.stdout.write(format_table(result) + "\n")
    fig = plot_payload_lift(result, out / "payload_lift_z.png")
    logger.info("wrote %s", fig)
    if args.json:
        text = json.dumps(rows_as_json(result.rows), indent=2)
        atomic_write(Path(args.json), lambda fh: fh.write(text.encode()))
        logger.info("wrote %s", args.json)
    return 0


def _run_monte_carlo(args: argparse.Namespace, base: Any, out: Path) -> int:
    """The Monte-Carlo study: table on stdout and in OUT, JSON, figure; failures at the end."""
    from dexlfd.errors import DexlfdError
    from dexlfd.experiments.payload_montecarlo import (
        MonteCarloConfig,
        format_monte_carlo,
        monte_carlo_json,
        run_payload_monte_carlo,
    )
    from dexlfd.io import atomic_write
    from dexlfd.viz.control import plot_payload_monte_carlo

    cfg = MonteCarloConfig(
        trials=args.trials, base=base, seed=args.seed, payload_kg=args.mc_payload_kg,
        model_error=args.mc_model_error, noise_scale=args.mc_noise_scale,
        torque_delay=args.mc_delay_ticks,
    )  # fmt: skip
    result = run_payload_monte_carlo(cfg, quiet=args.quiet)
    text = format_monte_carlo(result)
    sys.stdout.write(text + "\n")
    data = json.dumps(monte_carlo_json(result), indent=2).encode()
    written = [out / "payload_montecarlo.txt", out / "payload_montecarlo.json"]
    atomic_write(written[0], lambda fh: fh.write(text.encode() + b"\n"))
    atomic_write(written[1], lambda fh: fh.write(data))
    if args.json:
        atomic_write(Path(args.json), lambda fh: fh.write(data))
        written.append(Path(args.json))
    if result.trials:
        written.append(plot_payload_monte_carlo(result, out / "payload_montecarlo.png"))
    logger.info("wrote %s", ", ".join(map(str, written)))
    if result.failures:
        raise DexlfdError(
            f"{len(result.failures)} of {cfg.trials} trials failed (listed in the table and "
            f"{written[1]}); first: {result.failures[0].label}: {result.failures[0].error}"
        )
    return 0
