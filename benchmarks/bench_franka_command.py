"""Per-tick cost of the FER and FR3 command paths, offline (no robot, no simulator).

One cycle of the 1 kHz loop on a Franka (:func:`dexlfd.control.franka.run_controller`,
the one :class:`~dexlfd.control.arm_loop.ArmLoop` on a
:class:`~dexlfd.robot.franka_stream.StreamArm`) as each generation's stream drives
it: pylibfranka's read/write object (FR3) and libfranka 0.9's
``Robot.control(callback)`` (FER, panda-python), with duck-typed robots that hand
out a fixed state. The torque command object is the real binding's ``Torques``
where that binding is installed. The robot's model library needs a robot, so the
model terms come from the MuJoCo Panda model (the FR3's own model library costs
~16 µs per tick for M, C, G, J on franky-sim, see FACTS); the arm's own gravity
compensation G(q) reuses the law's last terms (libfranka's G alone costs a few
µs). The law is NTSM-PD.

    PYTHONPATH=src python benchmarks/bench_franka_command.py
"""

from __future__ import annotations

import importlib
import time
from types import SimpleNamespace

import numpy as np

from dexlfd.control import make_controller
from dexlfd.control.base import Reference
from dexlfd.control.franka import run_controller
from dexlfd.panda import Q_READY
from dexlfd.robot import MujocoPandaModel
from dexlfd.robot.franka import FrankaConfig
from dexlfd.robot.franka_stream import CallbackTorqueControl, TorqueControl
from dexlfd.robot.libfranka import state_from

N_CYCLES, REPEAT = 3000, 5


class _Raw:
    def __init__(self) -> None:
        T = np.eye(4)
        T[:3, 3] = (0.3, 0.0, 0.48)
        self.q, self.dq, self.tau_J = list(Q_READY), [0.0] * 7, [0.0] * 7
        self.O_T_EE = T.reshape(-1, order="F").tolist()
        self.F_T_EE = np.eye(4).reshape(-1).tolist()
        self.robot_mode, self.current_errors = "RobotMode.Move", []


class _Period:
    def to_sec(self) -> float:
        return 1e-3


RAW, PERIOD = _Raw(), _Period()


class _Active:  # pylibfranka's ActiveControl
    def readOnce(self):  # noqa: N802
        return RAW, PERIOD

    def writeOnce(self, cmd) -> None:  # noqa: N802
        pass


class _FerRobot:  # libfranka 0.9's Robot
    def control(self, callback, limit_rate: bool, cutoff_frequency: float) -> None:
        while not callback(RAW, PERIOD).motion_finished:
            pass


class _Model:
    def __init__(self, model: MujocoPandaModel) -> None:
        self.m = model

    def terms(self, q, dq):
        self.last = self.m.terms(q, dq)
        return self.last

    def gravity(self, q):
        return self.last.g if hasattr(self, "last") else self.m.terms(q, np.zeros(7)).g


MODEL = MujocoPandaModel()


class _Arm:
    host, config = "127.0.0.1", FrankaConfig()

    def __init__(self, stream) -> None:
        self.stream, self.model = stream, _Model(MODEL)

    def read_state(self):
        return state_from(RAW)

    def torque_control(self):
        return self.stream

    def stop_quietly(self) -> None:
        pass


def _torques(module: str):
    try:
        return importlib.import_module(module).Torques, module
    except ImportError:

        class _T:
            def __init__(self, tau) -> None:
                self.tau_J, self.motion_finished = list(tau), False

        return _T, "stand-in (binding not installed)"


def _reference() -> Reference:
    """1 cm above where the stand-in robot reports its TCP (no safety stop)."""
    T = np.array(RAW.O_T_EE).reshape(4, 4, order="F")
    z = np.zeros(3)
    return Reference(p=T[:3, 3] + (0.0, 0.0, 0.01), v=z, a=z, R=T[:3, :3], w=z)


def main() -> None:
    for gen, module in (("FR3", "pylibfranka"), ("FER", "panda_py.libfranka")):
        Torques, what = _torques(module)
        plf = SimpleNamespace(Torques=Torques)
        per_tick, cpu, compute = [], [], []
        for _ in range(REPEAT):
            if gen == "FR3":
                stream = TorqueControl(_Active(), plf, "127.0.0.1")
            else:
                stream = CallbackTorqueControl(_FerRobot(), plf, "127.0.0.1")
            arm, law, ref = _Arm(stream), make_controller("ntsm-pd"), _reference()
            t0, c0 = time.perf_counter(), time.process_time()
            _, stats = run_controller(
                arm, law, lambda i, t, ref=ref: ref, N_CYCLES, gripper_width=0.0
            )
            per_tick.append((time.perf_counter() - t0) / N_CYCLES * 1e6)
            cpu.append((time.process_time() - c0) / N_CYCLES * 1e6)
            compute.append(float(np.median(stats.compute_s)) * 1e6)
        print(
            f"{gen} ({what}): whole cycle {np.mean(per_tick):.1f} ± {np.std(per_tick):.1f} µs "
            f"wall, {np.mean(cpu):.1f} ± {np.std(cpu):.1f} µs CPU "
            "(model + law + limits + record + command object + the rollout at the end); "
            f"state-in to command-out median "
            f"{np.mean(compute):.1f} µs; {N_CYCLES} cycles x {REPEAT}"
        )


if __name__ == "__main__":
    main()
