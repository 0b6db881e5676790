"""Start a ``franky-sim`` Franka-protocol simulator confined to one loopback address.

This script runs inside the simulator's own virtual environment (franky-sim brings
MuJoCo + Pinocchio versions that clash with dexlfd's), so it imports nothing from
dexlfd. It differs from ``franky-sim -s mujoco --hostname HOST`` in four ways:

* every socket the simulator binds to the wildcard address (its UDP state socket
  does, see ``franky_sim.franka_server.FrankaServer._setup_udp_connection``) is
  bound to ``HOST`` instead, so no packet leaves the loopback interface;
* ``--payload-kg`` adds a rigid body to the hand that neither the simulator's
  gravity compensation (its Pinocchio model) nor the client's model knows: an
  unknown payload, as in the thesis's Table 5.1;
* ``--lockstep-s`` makes a torque motion wait for each command (up to that
  long) instead of stepping in real time, so tests are independent of how busy
  the host is (see ``_serve``);
* ``--reflex-after-s`` makes the simulated robot abort the first torque motion
  with a joint reflex after that much robot time under the client's commands
  (counted in commanded 1 ms cycles, so it does not depend on the host's
  speed), as a real arm does when a collision threshold is crossed (robot mode
  ``kReflex``, the error flag set, the Move command answered with
  ``kReflexAborted``); automatic error recovery clears it;
* ``--stall-after-cycles K --stall-cycles N`` makes the robot's clock run on for
  ``N`` cycles without sending a state after the ``K``-th commanded cycle of the
  first torque motion: what the client sees when its host stalls for ``N`` ms,
  made deterministic so the client's watchdog can be tested in lock-step.

It prints ``READY <host>`` on stdout once the robot (1337) and gripper (1338)
ports are bound, and shuts down cleanly on SIGTERM.

    python _franky_sim_launcher.py --host 127.0.0.1 --payload-kg 1.0
"""

from __future__ import annotations

import argparse
import select
import signal
import socket
import sys
import time
from typing import Any

_WILDCARDS = ("", "0.0.0.0")
# lock-step, before a torque motion's first command: when new states go out [s after the
# motion is confirmed], then every HOLD_STATE_PERIOD_S (see _serve)
HOLD_STATE_OFFSETS_S = (0.0, 0.02)
HOLD_STATE_PERIOD_S = 0.5
JOINT_REFLEX_INDEX = 6  # franka::Errors order: ..., joint_reflex is the 7th flag


def _confine_sockets(host: str) -> None:
    """Make any bind to the wildcard address bind to ``host`` instead."""
    original_bind = socket.socket.bind

    def bind(self: socket.socket, address: Any) -> None:
        if isinstance(address, tuple) and address and address[0] in _WILDCARDS:
            address = (host, *address[1:])
        original_bind(self, address)

    socket.socket.bind = bind  # type: ignore[method-assign,assignment]


def _die_with_parent() -> None:
    """Ask Linux to SIGTERM this process when its parent dies (no orphaned simulator)."""
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # PR_SET_DEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass


def _add_payload(sim: Any, mass_kg: float, com_m: tuple[float, float, float]) -> None:
    """Attach an inertial-only body (no geometry, so no contacts) to the hand."""
    import xml.etree.ElementTree as ET

    hand = sim.worldbody.find(".//body[@name='robot0_hand']")
    if hand is None:  # pragma: no cover - franky-sim changed its scene
        raise RuntimeError("franky-sim scene has no body 'robot0_hand'")
    body = ET.SubElement(hand, "body", name="dexlfd_payload", pos=" ".join(map(str, com_m)))
    # a solid 6 cm cube: I = m a^2 / 6
    inertia = mass_kg * 0.06**2 / 6.0
    ET.SubElement(body, "inertial", mass=str(mass_kg), pos="0 0 0", diaginertia=f"{inertia} " * 3)


def _install_reflex(sim: Any, server: Any, after_s: float) -> None:
    """Abort the first torque motion with a joint reflex ``after_s`` seconds into it."""
    import franky_sim.franka_robot_protocol as frp
    import franky_sim.franka_robot_server as frs
    from franky_sim.franka_robot_protocol import MoveStatus, RobotCommand, RobotMode
    from franky_sim.franka_server import BaseCommand

    rs = server.robot_servers[0]
    steps = {"torque": 0, "fired": False, "done": False}
    original_recovery = frp.AutomaticErrorRecoveryCommand.handle

    def recover(self: Any, server: Any) -> None:  # clears the reflex, as on the arm
        steps["fired"], steps["done"] = False, True
        original_recovery(self, server)

    frp.AutomaticErrorRecoveryCommand.handle = recover
    errors = tuple(i == JOINT_REFLEX_INDEX for i in range(41))
    original_state = frs.FrankaRobotServer.robot_state

    def robot_state(self: Any) -> Any:
        state = original_state.fget(self)
        if steps["fired"]:
            state = state.replace(robot_mode=RobotMode.kReflex, errors=errors, reflex_reason=errors)
        return state

    frs.FrankaRobotServer.robot_state = property(robot_state)

    def after_step(_sim: Any) -> None:
        if steps["fired"] or steps["done"]:
            return
        # count the cycles the client commanded (robot time under its control), not
        # the steps the robot idled while the client was still starting up
        commanded = rs._FrankaRobotServer__has_new_command
        if rs._FrankaRobotServer__control_mode is frs.ControlMode.TORQUE and commanded:
            steps["torque"] += 1
        if steps["torque"] >= round(after_s * 1000):
            steps["fired"] = True
            motion_id = rs.current_motion_id
            rs.stop_motion(send_preemption_signal=False)
            if motion_id:
                BaseCommand.send_response(
                    rs._tcp_socket, RobotCommand.kMove, motion_id, MoveStatus.kReflexAborted
                )

    sim.register_post_step_callback(after_step)


def _torque_mode(rs: Any) -> bool:
    """The robot server is in a torque motion."""
    import franky_sim.franka_robot_server as frs

    return bool(rs._FrankaRobotServer__control_mode is frs.ControlMode.TORQUE)


def _fresh(rs: Any) -> bool:
    """A command came in that answers the last state sent."""
    if not rs._FrankaRobotServer__has_new_command:
        return False
    answered = getattr(rs._FrankaRobotServer__current_control_command, "message_id", None)
    return answered is None or answered >= rs._FrankaServer__message_id - 1


def _wait_for_command(rs: Any, deadline: float) -> None:
    """Sleep in ``select`` until a fresh command, the end of the motion or ``deadline``."""
    udp = rs._FrankaServer__udp_socket
    while _torque_mode(rs) and not _fresh(rs) and (left := deadline - time.monotonic()) > 0:
        if udp is not None:
            select.select([udp], [], [], min(left, 0.01))
        else:  # pragma: no cover - the client is gone
            time.sleep(0.01)
        rs.process_commands()


def _send_held_state(rs: Any, held: list[float], now: float) -> None:
    """Before a motion's first command: a new state only on the hold schedule."""
    k = len(held)
    due = HOLD_STATE_OFFSETS_S[k] if k < len(HOLD_STATE_OFFSETS_S) else None
    if k == 0 or (
        now - held[0] >= due if due is not None else now - held[-1] >= HOLD_STATE_PERIOD_S
    ):
        rs.send_state()
        held.append(now)


def _serve(server: Any, lockstep_s: float | None, stall: tuple[int, int] | None = None) -> None:
    """franky-sim's 1 kHz loop; with ``lockstep_s``, a torque motion waits for commands.

    Real time (``None``): the simulation steps every 1 ms whether or not a command
    arrived, as a robot does. Lock-step: during a torque motion the clock advances
    one cycle per command that answers the last state sent (libfranka's robot
    time is the state's message id [ms]); each cycle waits up to ``lockstep_s``
    for it, sleeping in ``select`` so the client gets the CPU. Only a longer wait
    (a client that died) lets the clock run freely again until the next command.

    libfranka starts a motion by reading states without commanding, and its first
    read then waits for a state newer than the one that confirmed the motion. So
    until the first command the clock stands still (no physics step) and a new
    state goes out only at ``HOLD_STATE_OFFSETS_S`` (then every
    ``HOLD_STATE_PERIOD_S``): a client that starts slowly meets a few held states,
    not one per millisecond. A command answering an older state than the last one
    sent is stale (the client will read the newer one from its socket next) and
    does not advance the clock. A busy host therefore slows a test down; it can
    only add the held milliseconds of a motion's start to its robot time.

    ``stall = (K, N)``: after the ``K``-th commanded cycle of the first torque
    motion the clock runs on ``N`` cycles without a state reaching the client,
    as when the client's host stalls on a real robot (see the module docstring).
    """
    if lockstep_s is None and stall is None:
        server.run_forever()
        return
    rs = server.robot_servers[0]

    server.running = True
    free_running = False
    commanded = 0  # fresh commands in the current torque motion
    motions = 0  # torque motions done so far
    held: list[float] = []  # when states were sent while holding [s, monotonic]
    while server.running:
        start = time.monotonic()
        rs.process_commands()
        if not _torque_mode(rs):
            motions += commanded > 0
            commanded = 0
            held.clear()
        elif lockstep_s is not None:
            if commanded == 0 and not _fresh(rs):
                _send_held_state(rs, held, start)  # hold: no step (see the docstring)
                _wait_for_command(rs, start + 1e-3)
                if _torque_mode(rs) and not _fresh(rs):
                    continue
            if _fresh(rs):
                free_running = False
            elif not free_running:
                _wait_for_command(rs, start + lockstep_s)  # returns early if the motion ends
                free_running = _torque_mode(rs) and not _fresh(rs)
        if _torque_mode(rs) and _fresh(rs):
            commanded += 1
        server.sim.step()
        if stall is not None and motions == 0 and commanded == stall[0] and _torque_mode(rs):
            for _ in range(stall[1]):  # the clock runs on, no state reaches the client
                rs.process_commands()
                server.sim.step()
            rs._FrankaServer__message_id += stall[1]  # the states the client never got
            commanded += 1  # fire once
        rs.send_state()
        if lockstep_s is not None and _torque_mode(rs) and not free_running:
            continue  # lock-step: the client's commands pace the clock, not the wall
        time.sleep(max(0.0, 1e-3 - (time.monotonic() - start)))


def main(argv: list[str] | None = None) -> int:
    """Parse arguments, build the scene, serve until SIGTERM."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--host", default="127.0.0.1", help="loopback address to bind")
    parser.add_argument("--payload-kg", type=float, default=0.0, help="unknown payload [kg]")
    parser.add_argument(
        "--payload-com",
        type=float,
        nargs=3,
        default=(0.0, 0.0, 0.1034),
        help="payload centre of mass in the hand frame [m] (default: the TCP)",
    )
    parser.add_argument("--q0", type=float, nargs=7, default=None, help="initial joints [rad]")
    parser.add_argument("--reflex-after-s", type=float, default=None)
    parser.add_argument("--stall-after-cycles", type=int, default=None)
    parser.add_argument("--stall-cycles", type=int, default=0)
    parser.add_argument(
        "--lockstep-s", type=float, default=None,
        help="torque motions wait up to this long for each command (default: real time)",
    )  # fmt: skip
    args = parser.parse_args(argv)
    if not args.host.startswith("127."):
        parser.error(f"--host must be a loopback address 127.x.y.z, got {args.host}")

    _confine_sockets(args.host)
    _die_with_parent()

    def _stop(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, _stop)

    import franky_sim
    from franky_sim.mujoco_simulator import MujocoSimulator

    try:
        with MujocoSimulator(enable_visualization=False) as sim:
            kwargs = {} if args.q0 is None else {"initial_q": tuple(args.q0)}
            sim.add_robot(**kwargs)
            if args.payload_kg > 0.0:
                _add_payload(sim, args.payload_kg, tuple(args.payload_com))
            with franky_sim.SimulationServer(sim, hostname_candidates=[args.host]) as server:
                if args.reflex_after_s is not None:
                    _install_reflex(sim, server, args.reflex_after_s)
                sys.stdout.write(f"READY {args.host}\n")
                sys.stdout.flush()
                stall = None
                if args.stall_after_cycles is not None:
                    stall = (args.stall_after_cycles, args.stall_cycles)
                _serve(server, args.lockstep_s, stall)
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
