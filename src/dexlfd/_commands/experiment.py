"""``dexlfd experiment``: reproducible studies.

Examples
--------
    dexlfd experiment payload -o results/ --json table.json
    dexlfd experiment payload --workers 2 --duration-s 6
    dexlfd experiment payload --robot franky-sim -o study-franka/   # over the Franka protocol
    dexlfd experiment payload --trials 64 --workers 2 -o mc/       # Monte-Carlo, 95 % intervals
    dexlfd experiment payload --trials 1000 --engine ray --ray-address head:6379
    dexlfd experiment generalize model.npz -o gen/ --pairs 25 --payloads 0,1.2
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
    rough_duration,
    seed,
)
from dexlfd._commands._outputs import DIR, check_folder_files, check_outputs, record_written
from dexlfd._commands._sim_args import add_hand_arguments

logger = logging.getLogger(__name__)

MAX_WORKERS = 64  # processes; each simulation holds a MuJoCo model (~100 MB)
MAX_DURATION_S = 60.0  # [s] of the stand-in lift; every run simulates it at 1 kHz
MAX_TRIALS = 100_000  # Monte-Carlo plants: each runs every controller twice (~seconds each)
MAX_DELAY_TICKS = 100  # [1 ms ticks], as simulate --torque-delay
MAX_NOISE_SCALE = 100.0  # factor on the measurement noise

HELP = (
    "run a study (payload: Table 5.1 with an unknown payload; generalize: "
    "pick and place over the table)"
)


MAX_PAYLOADS = 20  # masses of one generalize study (each a column of its table)


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help=HELP,
    )
    p.add_argument("study", choices=["payload", "generalize"], help="which study")
    p.add_argument(
        "model", nargs="?", default=None,
        help="generalize: the learned model .npz (with grasp events, from dexlfd learn)",
    )  # fmt: skip
    _add_generalize_arguments(p)
    p.add_argument(
        "-o", "--output", default="payload-study", help="folder for figures (default: %(default)s)"
    )
    add_hand_arguments(p)
    p.add_argument(
        "--object", choices=["box", "cylinder", "sphere"], default="box",
        help="the object: the 6 x 5 x 6 cm box, or a cylinder or sphere 6 cm across "
        "(default: box)",
    )  # fmt: skip
    p.add_argument("--json", help="write the table rows as JSON to this file (.json)")
    p.add_argument(
        "--overwrite", action="store_true",
        help="replace files of the same names in OUTPUT that dexlfd did not write there",
    )  # fmt: skip
    p.add_argument(
        "--controllers", type=controller_list, default=None,
        help="comma-separated registry names, each once (default: "
        "pd,sm-pd,ntsm-pd,ntsm-pd-i,ntsm-pd-dob)",
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
    _add_monte_carlo_arguments(p)
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


def _add_generalize_arguments(p: argparse.ArgumentParser) -> None:
    """The ``generalize`` study's flags: grid pairs, payloads and the pick/place areas."""
    g = p.add_argument_group("generalize")
    g.add_argument(
        "--pairs", type=bounded_int(1, 10_000), default=25,
        help="pick/place pairs on the grid, 1..10000 (default: %(default)s)",
    )  # fmt: skip
    g.add_argument(
        "--payloads", default="0,1.2",
        help="object masses [kg], comma-separated, each in [0, 3] (0: a 10 g box; "
        "default: %(default)s)",
    )  # fmt: skip
    g.add_argument(
        "--pick-area", type=_area, default=((0.32, 0.62), (-0.45, -0.05)),
        help="X0,X1,Y0,Y1 [m] of the pick area (default 0.32,0.62,-0.45,-0.05)",
    )  # fmt: skip
    g.add_argument(
        "--place-area", type=_area, default=((0.32, 0.62), (0.05, 0.45)),
        help="X0,X1,Y0,Y1 [m] of the place area (default 0.32,0.62,0.05,0.45)",
    )  # fmt: skip


def _add_monte_carlo_arguments(p: argparse.ArgumentParser) -> None:
    """The Monte-Carlo flags: trials and the ranges every trial's plant is drawn from."""
    from dexlfd.experiments.payload import MAX_SIMULATED_S

    mc = p.add_argument_group(
        "Monte-Carlo (--trials N > 0): every trial draws a plant uniformly from these ranges "
        "and runs every controller with and without the object; means and 95 % intervals"
    )
    mc.add_argument(
        "--trials", type=bounded_int(0, MAX_TRIALS), default=0,
        help=f"random plants, 0..{MAX_TRIALS} (default 0: the Table 5.1 study on one plant); "
        f"a study simulates at most {MAX_SIMULATED_S:,.0f} s of robot time (trials x 2 x "
        "controllers x duration), more is refused before it starts",
    )  # fmt: skip
    mc.add_argument("--mc-payload-kg", type=_range(float, 0.0, 3.0), default=(0.2, 1.5),
                    help="object mass LO,HI [kg], within 0..3 (default 0.2,1.5)")  # fmt: skip
    mc.add_argument("--mc-model-error", type=_range(float, 0.0, 0.99), default=(0.0, 0.2),
                    help="model mass/inertia error LO,HI [-], within 0..0.99 "
                    "(default 0,0.2)")  # fmt: skip
    mc.add_argument("--mc-noise-scale", type=_range(float, 0.0, MAX_NOISE_SCALE),
                    default=(0.0, 2.0),
                    help="factor LO,HI on the measurement noise (1e-5 rad, 1e-3 rad/s), within "
                    f"0..{MAX_NOISE_SCALE:g} (default 0,2)")  # fmt: skip
    mc.add_argument("--mc-delay-ticks", type=_range(int, 0, MAX_DELAY_TICKS), default=(0, 2),
                    help=f"torque delay LO,HI [1 ms ticks], within 0..{MAX_DELAY_TICKS} "
                    "(default 0,2)")  # fmt: skip


def _area(text: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """Argparse type: ``X0,X1,Y0,Y1`` [m] with X0 < X1, Y0 < Y1."""
    try:
        x0, x1, y0, y1 = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X0,X1,Y0,Y1 [m], got {text!r}") from None
    if not (x0 < x1 and y0 < y1) or not all(abs(v) <= 1.0 for v in (x0, x1, y0, y1)):
        raise argparse.ArgumentTypeError(
            f"expected X0 < X1 and Y0 < Y1 within [-1, 1] m, got {text!r}"
        )
    return (x0, x1), (y0, y1)


def _range(kind: type, lo_max: float, hi_max: float) -> Any:
    """Argparse type: ``LO,HI`` with ``lo_max <= LO <= HI <= hi_max``."""

    def parse(text: str) -> tuple[Any, Any]:
        try:
            lo, hi = (kind(v) for v in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected LO,HI ({kind.__name__}s), got {text!r}"
            ) from None
        if not lo_max <= lo <= hi <= hi_max:  # NaN is never inside
            raise argparse.ArgumentTypeError(
                f"expected {lo_max:g} <= LO <= HI <= {hi_max:g}, got {text!r}"
            )
        return lo, hi

    return parse


def controller_list(text: str) -> tuple[str, ...]:
    """Argparse type: comma-separated controller registry names, each once, at least one."""
    from dexlfd.control import CONTROLLERS

    names = tuple(c.strip() for c in text.split(","))
    if not text.strip() or not all(names):
        raise argparse.ArgumentTypeError(f"expected NAME[,NAME...], got {text!r}")
    unknown = [n for n in names if n not in CONTROLLERS]
    if unknown:
        raise argparse.ArgumentTypeError(
            f"unknown controller {unknown[0]!r}; one of {', '.join(sorted(CONTROLLERS))}"
        )
    if len(set(names)) < len(names):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise argparse.ArgumentTypeError(f"{', '.join(twice)} named twice")
    return names


def run(args: argparse.Namespace) -> int:
    """Run the study, print the table, write figures and JSON."""
    check_outputs(
        [("-o/--output", args.output, DIR), ("--json", args.json, ".json")],
        inputs=[p for p in (args.plan, args.model) if p],
    )  # fail now, not after the study
    if args.study == "payload" and args.model is not None:
        from dexlfd.errors import InvalidInput

        raise InvalidInput(
            f"experiment payload takes no MODEL (got {args.model}): it tracks --plan, or a "
            "stand-in lift; a learned model is for experiment generalize"
        )
    check_folder_files("-o/--output", args.output, _written_names(args), overwrite=args.overwrite)
    if args.robot == "franky-sim":
        from dexlfd._commands._franka import run_protocol_study
        from dexlfd.errors import InvalidInput

        if args.trials or args.engine != "local" or args.end_effector != "franka":
            raise InvalidInput("--trials, --engine ray and --hand softhand need --robot mujoco")

        return run_protocol_study(args)
    if args.study == "generalize":
        return _run_generalize(args)
    from dexlfd.experiments.payload import PayloadConfig, check_workload

    kwargs: dict[str, Any] = {
        "duration": args.duration_s, "model_error": args.model_error,
        "workers": args.workers, "seed": args.seed, "engine": args.engine,
        "ray_address": args.ray_address, "hand": args.end_effector, "stop_force": args.stop_force,
        "shape": args.object,
    }  # fmt: skip
    if args.plan:
        from dexlfd.io import load_plan
        from dexlfd.robot import plan_world

        plan = load_plan(args.plan)
        kwargs["plan"] = plan
        kwargs["obstacles"] = plan_world(plan)
    if args.controllers:
        kwargs["controllers"] = args.controllers
    cfg = PayloadConfig(**kwargs)
    check_workload(cfg, args.trials)  # before any run or output
    out = ensure_output_dir(args.output)
    if args.trials:
        return _run_monte_carlo(args, cfg, out)
    from dexlfd.experiments.payload import format_table, rows_as_json, run_payload_experiment
    from dexlfd.io import atomic_write
    from dexlfd.viz.control import plot_payload_lift

    result = run_payload_experiment(cfg, quiet=args.quiet)
    sys.stdout.write(format_table(result) + "\n")
    fig = plot_payload_lift(result, out / "payload_lift_z.png")
    record_written(out, [fig])
    logger.info("wrote %s", fig)
    if args.json:
        text = json.dumps(rows_as_json(result.rows), indent=2)
        atomic_write(Path(args.json), lambda fh: fh.write(text.encode()))
        logger.info("wrote %s", args.json)
    stopped = [r for r in result.rows if r.stopped]
    if stopped and len(stopped) == len(result.rows):  # no E_OB measured: the table is nan
        from dexlfd.errors import DexlfdError

        first = stopped[0]
        raise DexlfdError(
            f"every one of the {len(stopped)} runs with the object stopped (first: "
            f"{first.controller} {first.payload_kg:g} kg: {first.stopped}), so no error over "
            "the obstacle was measured (the table and figure show where they stopped): "
            "slow the motion (--duration-s, --plan) or lower --model-error"
        )
    return 0


def _check_generalize_workload(
    pairs: int, controllers: int, payloads: int, span: float, workers: int = 1
) -> None:
    """Say, before any run, the study's robot time and its duration; refuse past the bound.

    The duration is for ``workers`` cores not shared with other work.

    Each pair is planned once (:data:`~dexlfd.experiments.generalize.PLAN_CPU_S` of CPU)
    and simulated per controller and payload, the object's contacts included
    (:data:`~dexlfd.experiments.generalize.TASK_SIM_SPEED_X`); a run lasts about the
    model's duration ``span`` [s] (a pick-and-place plan a little longer).
    """
    from dexlfd.errors import InvalidInput
    from dexlfd.experiments.generalize import PLAN_CPU_S, TASK_SIM_SPEED_X
    from dexlfd.experiments.payload import MAX_SIMULATED_S

    runs = pairs * controllers * payloads
    total = runs * span
    wall = (pairs * PLAN_CPU_S + total / TASK_SIM_SPEED_X) / max(1, workers)
    logger.info(
        "generalize: %d pair(s) x %d controller(s) x %d payload(s) = %d runs of ~%.3g s: "
        "~%.3g s of robot time, about %s on %d quiet core(s)",
        pairs, controllers, payloads, runs, span, total, rough_duration(wall), max(1, workers),
    )  # fmt: skip
    if total > MAX_SIMULATED_S:
        raise InvalidInput(
            f"--pairs {pairs} x --controllers {controllers} x --payloads {payloads} = {runs} "
            f"runs of ~{span:.3g} s, ~{total:.3g} s of robot time; at most "
            f"{MAX_SIMULATED_S:,.0f} s: fewer --pairs, --payloads or --controllers"
        )


def _written_names(args: argparse.Namespace) -> list[str]:
    """The files the study writes in its OUTPUT folder."""
    if args.study == "generalize":
        return ["generalize.txt", "generalize.json", "generalize.png"]
    if args.trials:
        return ["payload_montecarlo.txt", "payload_montecarlo.json", "payload_montecarlo.png"]
    return ["payload_lift_z.png"]


def _run_generalize(args: argparse.Namespace) -> int:
    """Plan, simulate and score the pick/place grid; table, figure, JSON, report."""
    from dexlfd.errors import InvalidInput
    from dexlfd.experiments.generalize import (
        GeneralizeConfig,
        check_areas,
        format_generalize,
        generalize_json,
        run_generalize,
    )
    from dexlfd.io import atomic_write, load_model
    from dexlfd.viz.control import plot_generalize

    if args.model is None:
        raise InvalidInput("experiment generalize needs MODEL (a learned model .npz)")
    try:
        payloads = tuple(float(v) for v in args.payloads.split(","))
    except ValueError:
        raise InvalidInput(
            f"--payloads {args.payloads!r}: expected masses [kg], e.g. 0,1.2"
        ) from None
    if not payloads or any(not (0.0 <= m <= 3.0) for m in payloads):
        raise InvalidInput(f"--payloads {args.payloads!r}: each mass must be in [0, 3] kg")
    if len(set(payloads)) < len(payloads) or len(payloads) > MAX_PAYLOADS:
        raise InvalidInput(
            f"--payloads: {len(payloads)} masses; expected 1..{MAX_PAYLOADS} different ones"
        )
    for msg in check_areas([args.pick_area, args.place_area]):
        logger.warning("%s: the study's claim needs at least 30 x 40 cm", msg)
    if args.pairs < 25:
        logger.warning("--pairs %d: the study's claim needs at least 25 pairs", args.pairs)
    out = ensure_output_dir(args.output)
    model = load_model(args.model)
    controllers = args.controllers or ("ntsm-pd",)
    _check_generalize_workload(
        args.pairs, len(controllers), len(payloads), float(model.t[-1]), args.workers
    )
    cfg = GeneralizeConfig(
        n_pairs=args.pairs, pick_area=args.pick_area, place_area=args.place_area,
        controllers=controllers, payloads=payloads, model_error=args.model_error,
        seed=args.seed, workers=args.workers, engine=args.engine,
        ray_address=args.ray_address, hand=args.end_effector, shape=args.object,
        stop_force=args.stop_force,
    )  # fmt: skip
    result = run_generalize(model, cfg, quiet=args.quiet)
    text = format_generalize(result)
    sys.stdout.write(text + "\n")
    data = json.dumps(generalize_json(result), indent=2, default=str).encode()
    written = [out / "generalize.txt", out / "generalize.json"]
    atomic_write(written[0], lambda fh: fh.write(text.encode() + b"\n"))
    atomic_write(written[1], lambda fh: fh.write(data))
    if args.json:
        atomic_write(Path(args.json), lambda fh: fh.write(data))
        written.append(Path(args.json))
    written.append(plot_generalize(result, out / "generalize.png"))
    record_written(out, written)
    logger.info("wrote %s", ", ".join(map(str, written)))
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
    record_written(out, written)
    logger.info("wrote %s", ", ".join(map(str, written)))
    if result.failures:
        raise DexlfdError(
            f"{len(result.failures)} of {cfg.trials} trials failed (listed in the table and "
            f"{written[1]}); first: {result.failures[0].label}: {result.failures[0].error}"
        )
    return 0
