"""Simulation flags shared by ``simulate`` and ``teleop``: controller, plant, sensing."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from dexlfd._commands._common import bounded_float, seed
from dexlfd.panda import MAX_PAYLOAD

__all__ = ["SIM_FLAGS", "add_sim_arguments", "sim_setup"]

# library parameter -> flag of these options, for errors (cli.speak_cli)
SIM_FLAGS = {
    "payload_kg": "--payload",
    "model error": "--model-error",
    "torque_delay": "--torque-delay",
}


def add_sim_arguments(p: argparse.ArgumentParser, *, payload_help: str) -> None:
    """Register --controller, --payload, --model-error, --no-friction, --no-noise, --seed."""
    from dexlfd.control import CONTROLLERS

    p.add_argument(
        "--controller", default="ntsm-pd", choices=sorted(CONTROLLERS),
        help="control law (default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--payload", type=bounded_float(0.0, MAX_PAYLOAD), default=0.0,
        help=f"{payload_help}; 0..{MAX_PAYLOAD:g} kg (the Panda's rated payload; default: 0)",
    )  # fmt: skip
    p.add_argument(
        "--model-error", type=bounded_float(0.0, 0.99), default=0.1,
        help="relative mass/inertia error of the controller's model, 0..0.99 "
        "(default: %(default)s)",
    )  # fmt: skip
    p.add_argument("--no-friction", action="store_true", help="switch joint friction off")
    p.add_argument("--no-noise", action="store_true", help="no measurement noise")
    p.add_argument(
        "--seed", type=seed, default=0, help="random seed, 0..2**32-1 (default: %(default)s)"
    )


def sim_setup(args: argparse.Namespace, **plant_kwargs: Any) -> tuple[Any, Any, Any, Any]:
    """``(plant, loop, controller, model)`` from the flags of :func:`add_sim_arguments`.

    ``plant_kwargs`` go to :class:`~dexlfd.robot.PlantConfig` (e.g. obstacles); a
    ``--torque-delay`` flag, where the command has one, goes to the loop.
    """
    from dexlfd.control import LoopConfig, make_controller
    from dexlfd.robot import PlantConfig, perturbed_model

    plant = PlantConfig(
        payload_kg=args.payload,
        friction_scale=0.0 if args.no_friction else 1.0,
        **plant_kwargs,
    )
    default = LoopConfig()
    loop = LoopConfig(
        q_noise=0.0 if args.no_noise else default.q_noise,
        dq_noise=0.0 if args.no_noise else default.dq_noise,
        torque_delay=getattr(args, "torque_delay", default.torque_delay),
    )
    controller = make_controller(args.controller)
    model = perturbed_model(args.model_error, np.random.default_rng([args.seed, 1]))
    return plant, loop, controller, model
