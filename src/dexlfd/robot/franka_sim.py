"""A Franka-protocol simulator (``franky-sim``) in its own virtual environment, on loopback.

``franky-sim`` serves the Franka robot (port 1337) and gripper (port 1338)
protocols from a MuJoCo simulation of an FR3, so the real-arm path
(:mod:`dexlfd.robot.franka`) can be run end to end without a robot. Its
dependencies (MuJoCo and Pinocchio builds that pull numpy 2) clash with
dexlfd's, so it lives in a separate virtual environment created once and
cached per version (:func:`ensure_simulator_venv`). :class:`FrankaSimServer`
starts it bound to one loopback address (every socket, UDP included: see
``_franky_sim_launcher.py``), waits until it serves, and stops it by its PID.

    python = ensure_simulator_venv(Path(".venv-franka-sim"))
    with FrankaSimServer(python, payload_kg=1.0) as sim:
        with FrankaArm(sim.host) as arm:
            ...
"""

from __future__ import annotations

import logging
import math
import os
import select
import signal
import socket
import subprocess
import time
from collections.abc import Sequence
from pathlib import Path

from dexlfd._venv import ensure_venv
from dexlfd.errors import DexlfdError, InvalidInput

__all__ = [
    "FRANKY_SIM_REQUIREMENT",
    "FrankaSimServer",
    "SimulatorUnavailable",
    "ensure_simulator_venv",
    "free_loopback_host",
    "simulator_python",
]

logger = logging.getLogger(__name__)

FRANKY_SIM_REQUIREMENT = "franky-sim==1.0.4"
ROBOT_PORT, GRIPPER_PORT = 1337, 1338  # fixed by the Franka protocol
LAUNCHER = Path(__file__).with_name("_franky_sim_launcher.py")


class SimulatorUnavailable(DexlfdError):
    """The simulator's virtual environment cannot be created or the simulator does not start."""


def simulator_python(root: Path) -> Path:
    """Python of the cached simulator environment under ``root`` (keyed by version)."""
    name = FRANKY_SIM_REQUIREMENT.replace("==", "-")
    return Path(root) / name / "bin" / "python"


def ensure_simulator_venv(
    root: Path, *, base_python: str | None = None, timeout_s: float = 1200.0
) -> Path:
    """Create (once) the virtual environment with ``franky-sim`` and return its Python.

    Parameters
    ----------
    root : Path
        Cache folder (e.g. ``.venv-franka-sim/``, ignored by git); the environment is
        ``root/franky-sim-<version>/``, marked complete by a ``.installed`` file.
    base_python : str or None
        Interpreter used to create the environment; default: this one's base.
    timeout_s : float
        Limit for creating and installing [s].

    Raises
    ------
    SimulatorUnavailable
        If ``venv`` or ``pip install`` fails (e.g. no package index reachable); the
        message ends with pip's last output lines.
    """
    return ensure_venv(
        simulator_python(root),
        [[FRANKY_SIM_REQUIREMENT]],
        what="simulator",
        error=SimulatorUnavailable,
        base_python=base_python,
        timeout_s=timeout_s,
    )


def _ports_free(host: str) -> bool:
    for port in (ROBOT_PORT, GRIPPER_PORT):
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            try:
                s.bind((host, port))
            except OSError:
                return False
    return True


def free_loopback_host(seed: int | None = None) -> str:
    """A loopback address ``127.x.y.z`` whose Franka ports are free.

    The protocol fixes the ports, so parallel simulators (other test runs on the
    same machine) need distinct addresses; ``seed`` (default: this process id)
    picks where the search starts.
    """
    start = (os.getpid() if seed is None else seed) % 65024
    for k in range(256):
        n = (start + 7919 * k) % 65024 + 256  # 127.77.1.0 .. 127.77.255.255
        host = f"127.77.{n >> 8}.{n & 255}"
        if _ports_free(host):
            return host
    raise SimulatorUnavailable("no loopback address with free ports 1337/1338 found")


class FrankaSimServer:
    """``franky-sim`` on one loopback address, as a context manager.

    Parameters
    ----------
    python : Path
        Interpreter of the simulator environment (:func:`ensure_simulator_venv`).
    host : str or None
        Loopback address ``127.x.y.z``; default: :func:`free_loopback_host`.
    payload_kg : float
        Mass of an extra body on the hand that neither the simulator's gravity
        compensation nor the client's model knows [kg].
    reflex_after_s : float or None
        Abort the first torque motion with a joint reflex after this time [s].
    q0 : sequence of 7 floats or None
        Initial joint positions [rad]; default: franky-sim's (0, 0, 0, −1.57, 0, 1.57, 0.785).
    lockstep_s : float or None
        None: real time (cycles the client misses are lost, as on a robot). A
        value: the robot's clock stands still until a torque motion's first
        command, then every cycle waits up to that long [s] for the client's
        command, so robot time, states and results do not depend on how busy the
        host is (tests use this, with a generous value such as 60 s).
    stall_after_cycles, stall_cycles : int or None, int
        Deterministic host stall: after the ``stall_after_cycles``-th commanded
        cycle of the first torque motion, the robot's clock runs on for
        ``stall_cycles`` cycles [1 ms] before the next state reaches the client
        (tests the client's watchdog in lock-step).
    start_timeout_s : float
        Time allowed for the simulator to start serving [s].
    """

    def __init__(
        self,
        python: Path,
        host: str | None = None,
        *,
        payload_kg: float = 0.0,
        reflex_after_s: float | None = None,
        q0: Sequence[float] | None = None,
        lockstep_s: float | None = None,
        stall_after_cycles: int | None = None,
        stall_cycles: int = 0,
        start_timeout_s: float = 300.0,
    ) -> None:
        if host is not None and not host.startswith("127."):
            raise InvalidInput(f"host must be a loopback address 127.x.y.z, got {host!r}")
        if not (0.0 <= payload_kg <= 3.0):
            raise InvalidInput(f"payload_kg must be in [0, 3] kg, got {payload_kg}")
        self.python = Path(python)
        self.host = host or free_loopback_host()
        self.payload_kg = payload_kg
        self.reflex_after_s = reflex_after_s
        self.q0 = None if q0 is None else [float(v) for v in q0]
        if self.q0 is not None and (len(self.q0) != 7 or not all(map(math.isfinite, self.q0))):
            raise InvalidInput(f"q0 must be 7 finite joint angles [rad], got {q0!r}")
        if lockstep_s is not None and not (0.0 < lockstep_s <= 600.0):
            raise InvalidInput(f"lockstep_s must be in (0, 600] s or None, got {lockstep_s}")
        if stall_after_cycles is not None and not (
            stall_after_cycles >= 1 and 1 <= stall_cycles <= 10_000
        ):
            raise InvalidInput(
                "stall_after_cycles must be >= 1 and stall_cycles in [1, 10000], "
                f"got {stall_after_cycles}, {stall_cycles}"
            )
        self.lockstep_s = lockstep_s
        self.stall = None if stall_after_cycles is None else (stall_after_cycles, stall_cycles)
        self.start_timeout_s = start_timeout_s
        self._proc: subprocess.Popen[str] | None = None

    @property
    def pid(self) -> int | None:
        """Process id of the running simulator."""
        return None if self._proc is None else self._proc.pid

    @property
    def url(self) -> str:
        """``franka://HOST`` of this simulator."""
        return f"franka://{self.host}"

    def start(self) -> FrankaSimServer:
        """Start the simulator and wait until it serves; raises :class:`SimulatorUnavailable`."""
        if not self.python.is_file():
            raise SimulatorUnavailable(f"simulator interpreter {self.python} does not exist")
        cmd = [str(self.python), str(LAUNCHER), "--host", self.host]
        if self.payload_kg > 0:
            cmd += ["--payload-kg", repr(self.payload_kg)]
        if self.reflex_after_s is not None:
            cmd += ["--reflex-after-s", repr(self.reflex_after_s)]
        if self.q0 is not None:
            cmd += ["--q0", *map(repr, self.q0)]
        if self.lockstep_s is not None:
            cmd += ["--lockstep-s", repr(self.lockstep_s)]
        if self.stall is not None:
            cmd += ["--stall-after-cycles", str(self.stall[0])]
            cmd += ["--stall-cycles", str(self.stall[1])]
        self._proc = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, bufsize=1
        )
        deadline = time.monotonic() + self.start_timeout_s
        assert self._proc.stdout is not None  # PIPE above
        while time.monotonic() < deadline:
            ready, _, _ = select.select([self._proc.stdout], [], [], 0.2)
            if ready:
                line = self._proc.stdout.readline()
                if line.startswith("READY"):
                    logger.info("franky-sim serving on %s (pid %d)", self.host, self._proc.pid)
                    return self
            if self._proc.poll() is not None:
                err = self._proc.stderr.read() if self._proc.stderr else ""
                self._proc = None
                tail = "\n".join(err.strip().splitlines()[-5:])
                raise SimulatorUnavailable(f"franky-sim exited while starting:\n{tail}")
        self.stop()
        raise SimulatorUnavailable(f"franky-sim did not start within {self.start_timeout_s} s")

    def stop(self, grace_s: float = 5.0) -> None:
        """SIGTERM the simulator by its PID, then SIGKILL after ``grace_s`` (idempotent)."""
        proc, self._proc = self._proc, None
        if proc is None:
            return
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=grace_s)
            except subprocess.TimeoutExpired:
                logger.warning("franky-sim (pid %d) ignored SIGTERM; killing it", proc.pid)
                proc.kill()
                proc.wait(timeout=grace_s)
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()

    def kill(self) -> None:
        """SIGKILL the simulator at once (a dropped connection, for tests)."""
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait()

    def __enter__(self) -> FrankaSimServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
