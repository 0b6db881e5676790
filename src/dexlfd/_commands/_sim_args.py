"""Simulation flags shared by ``simulate`` and ``teleop``: controller, plant, sensing."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from dexlfd._commands._common import bounded_float, seed
from dexlfd._commands._fields import add_params, alias, metres_hint

__all__ = ["add_sim_arguments", "sim_setup"]


def add_sim_arguments(
    p: argparse.ArgumentParser, *, payload_help: str, end_effector: bool = True
) -> None:
    """Register the controller, plant and sensing flags.

    --controller, --payload-kg, --model-error, --hand, --stop-force-n, --object,
    --object-size-m, --no-friction, --no-noise, --seed. Without ``end_effector``, or where
    the command has its own ``--hand`` (the demonstrating hand), no --hand and
    --stop-force-n (the Franka Hand); where it has its own ``--object-size-m``, no --object
    and --object-size-m.
    """
    from dexlfd.control import CONTROLLERS

    p.add_argument(
        "--controller", default="ntsm-pd", choices=sorted(CONTROLLERS),
        help="control law (default: %(default)s)",
    )  # fmt: skip
    from dexlfd.robot.plant import PlantConfig

    add_params(p, PlantConfig, ["payload_kg"], notes={"payload_kg": payload_help},
               dests={"payload_kg": "payload"})  # fmt: skip
    p.add_argument(
        "--model-error", type=bounded_float(0.0, 0.99), default=0.1,
        help="relative mass/inertia error of the controller's model, 0..0.99 "
        "(default: %(default)s)",
    )  # fmt: skip
    own = p._option_string_actions  # flags the command already has keep its meaning
    if end_effector and "--hand" not in own:
        add_hand_arguments(p)
    if "--object-size-m" not in own:
        _add_object_arguments(p)
    p.add_argument("--no-friction", action="store_true", help="switch joint friction off")
    p.add_argument("--no-noise", action="store_true", help="no measurement noise")
    p.add_argument(
        "--seed", type=seed, default=0, help="random seed, 0..2**32-1 (default: %(default)s)"
    )


def _add_object_arguments(p: argparse.ArgumentParser) -> None:
    """Register --object and --object-size-m (the object the simulated hand picks)."""
    p.add_argument(
        "--object", choices=["box", "cylinder", "sphere"], default="box",
        help="the object to pick: a box, an upright cylinder or a sphere (default: box)",
    )  # fmt: skip
    size = p.add_argument(
        "--object-size-m", type=_size, default=None, dest="object_size",
        help="X,Y,Z: the object's size [m] in the gripper frame (Y across the fingers; a "
        "cylinder's diameter is X = Y, a sphere's X = Y = Z); default 0.06,0.05,0.06 "
        "(a sphere and a cylinder 0.06 across)",
    )  # fmt: skip
    alias(p, size, "--object-size")


def add_hand_arguments(p: argparse.ArgumentParser) -> None:
    """Register --hand and --stop-force-n (the end-effector of the simulated Panda)."""
    p.add_argument(
        "--hand", choices=["franka", "softhand"], default="franka", dest="end_effector",
        help="end-effector: the Franka Hand (parallel fingers, 70 N) or a simulated qb "
        "SoftHand (one synergy, closes around the object, stops at --stop-force-n; "
        "default: franka)",
    )  # fmt: skip
    from dexlfd.robot.plant import PlantConfig

    add_params(p, PlantConfig, ["stop_force"], dests={"stop_force": "stop_force"})


def _size(text: str) -> tuple[float, float, float]:
    """``X,Y,Z`` [m] -> half sizes; each in (0, 0.3]."""
    try:
        v = tuple(float(x) for x in text.split(","))
    except ValueError:
        v = ()
    if len(v) != 3 or not all(0 < x <= 0.3 for x in v):
        hint = metres_hint(v, lambda x: 0 < x <= 0.3) if len(v) == 3 else ""
        raise argparse.ArgumentTypeError(f"expected X,Y,Z in (0, 0.3] m, got {text!r}{hint}")
    return (0.5 * v[0], 0.5 * v[1], 0.5 * v[2])


def object_half_size(
    shape: str, size: tuple[float, float, float] | None
) -> tuple[float, float, float]:
    """Half sizes [m] of the ``--object`` of ``--object-size-m`` (default per shape)."""
    from dexlfd.robot.plant import HALF_SIZES

    return HALF_SIZES[shape] if size is None else size


def sim_setup(args: argparse.Namespace, **plant_kwargs: Any) -> tuple[Any, Any, Any, Any]:
    """``(plant, loop, controller, model)`` from the flags of :func:`add_sim_arguments`.

    ``plant_kwargs`` go to :class:`~dexlfd.robot.PlantConfig` (e.g. obstacles); a
    ``--torque-delay-ticks`` flag, where the command has one, goes to the loop.
    """
    from dexlfd.control import LoopConfig, make_controller
    from dexlfd.robot import PlantConfig, perturbed_model

    plant = PlantConfig(
        payload_kg=args.payload,
        friction_scale=0.0 if args.no_friction else 1.0,
        hand=getattr(args, "end_effector", "franka"),
        stop_force=getattr(args, "stop_force", 3.0),
        payload_shape=getattr(args, "object", "box"),
        payload_half_size=object_half_size(
            getattr(args, "object", "box"), getattr(args, "object_size", None)
        ),
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
