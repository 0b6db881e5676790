"""Both Franka generations without a robot: binding choice, mismatch, the command stream.

The FER's binding (``panda-python``, libfranka 0.9.2, robot protocol 5) speaks to
no Franka-protocol simulator (franky-sim and franka-sim serve protocol 10), so
what can run without a FER runs here: the connect handshake against a fake robot
that answers with another protocol version (libfranka's own version check), a
refused connection, and the command stream's limits through both streams
(pylibfranka's read/write object and libfranka 0.9's ``Robot.control(callback)``)
with duck-typed robots. Tests that need ``panda_py`` skip without it.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import textwrap
from types import SimpleNamespace

import numpy as np
import pytest

from dexlfd.control import Reference
from dexlfd.control.franka import run_controller
from dexlfd.panda import Q_READY, TAU_MAX
from dexlfd.robot.franka import FrankaArm, FrankaConfig
from dexlfd.robot.franka_bindings import (
    BINDINGS,
    generation_of_protocol,
    mismatch_message,
    server_version_of,
)
from dexlfd.robot.franka_sim import free_loopback_host
from dexlfd.robot.franka_stream import CallbackTorqueControl, TorqueControl
from dexlfd.robot.libfranka import RobotConnectionError, state_from

HAS_PANDA_PY = importlib.util.find_spec("panda_py") is not None
HAS_PYLIBFRANKA = importlib.util.find_spec("pylibfranka") is not None
needs_panda_py = pytest.mark.skipif(not HAS_PANDA_PY, reason="panda-python (FER) not installed")
needs_pylibfranka = pytest.mark.skipif(not HAS_PYLIBFRANKA, reason="pylibfranka not installed")

# a robot that answers libfranka's Connect with "incompatible library version" and its own
# protocol version; it prints the version the client asked for (libfranka's own)
_FAKE_ROBOT = textwrap.dedent(
    """
    import socket, struct, sys
    srv = socket.socket()
    srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    srv.bind((sys.argv[1], 1337)); srv.listen(1)
    print("READY", flush=True)
    srv.settimeout(20)
    c, _ = srv.accept()
    cmd, cid, size = struct.unpack("<III", c.recv(12))
    client_version, = struct.unpack("<H", c.recv(size - 12)[:2])
    print("CLIENT", client_version, flush=True)
    c.sendall(struct.pack("<III", 0, cid, 12 + 8) + struct.pack("<BH5x", 1, int(sys.argv[2])))
    c.recv(1)
    """
)


def _connect_to_fake(version: int, generation: str, seed: int) -> tuple[str, int]:
    """The error text of connecting to a fake robot of protocol ``version``; client's version."""
    host = free_loopback_host(seed=seed)
    proc = subprocess.Popen(
        [sys.executable, "-c", _FAKE_ROBOT, host, str(version)], stdout=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "READY"
        with pytest.raises(RobotConnectionError) as exc, FrankaArm(host, generation=generation):
            pass
        client = int(proc.stdout.readline().split()[1])
        return str(exc.value), client
    finally:
        proc.kill()
        proc.wait()
        assert proc.stdout is not None
        proc.stdout.close()


def test_protocol_versions_map_to_generations() -> None:
    assert [generation_of_protocol(v) for v in (3, 4, 5, 6, 9, 10)] == ["fer"] * 3 + ["fr3"] * 3
    text = "libfranka: Incompatible library version (server version: 5, library version: 10)."
    assert server_version_of(RuntimeError(text)) == 5
    assert server_version_of(SimpleNamespace(server_version=10)) == 10  # panda-python's error
    assert server_version_of(RuntimeError("Connection to FCI refused")) is None


@pytest.mark.parametrize(("used", "version", "found"), [("fr3", 5, "fer"), ("fer", 10, "fr3")])
def test_mismatch_is_one_line_naming_the_generation_and_the_extra(used, version, found) -> None:
    text = mismatch_message("10.0.0.2", BINDINGS[used], version)
    assert "\n" not in text
    assert BINDINGS[found].label in text and f"protocol {version}" in text
    assert f"pip install 'dexlfd[{BINDINGS[found].extra}]'" in text
    assert f"--franka-generation {found}" in text


@needs_pylibfranka
def test_fr3_binding_meets_a_fer(tmp_path) -> None:
    text, client = _connect_to_fake(5, "fr3", seed=1301)
    assert client == 10  # libfranka 0.21.3 asked for protocol 10
    assert "\n" not in text
    assert "is a Franka Emika Panda (FER) (robot protocol 5)" in text
    assert "pip install 'dexlfd[franka-fer]'" in text and "--franka-generation fer" in text


@needs_pylibfranka
def test_fr3_binding_meets_an_older_fr3_image() -> None:
    text, _ = _connect_to_fake(9, "fr3", seed=1303)
    assert "speaks robot protocol 9" in text and "speaks 10" in text


@needs_panda_py
def test_fer_binding_meets_an_fr3() -> None:
    text, client = _connect_to_fake(10, "fer", seed=1307)
    assert client == 5  # panda-python's libfranka 0.9.2 asked for protocol 5
    assert "\n" not in text
    assert "is a Franka Research 3 (FR3) (robot protocol 10)" in text
    assert "pip install 'dexlfd[franka]'" in text and "--franka-generation fr3" in text


@pytest.mark.skipif(HAS_PANDA_PY, reason="checks auto without panda-python installed")
@needs_pylibfranka
def test_auto_without_the_fer_binding_names_its_extra() -> None:
    text, _ = _connect_to_fake(5, "auto", seed=1319)
    assert "pip install 'dexlfd[franka-fer]'" in text


@needs_panda_py
def test_fer_binding_connection_refused() -> None:
    host = free_loopback_host(seed=1311)  # free ports: nothing serves there
    with (
        pytest.raises(RobotConnectionError, match="cannot reach a Franka arm"),
        FrankaArm(host, generation="fer"),
    ):
        pass


def test_unknown_generation_is_refused() -> None:
    from dexlfd.errors import InvalidInput

    with pytest.raises(InvalidInput, match="generation must be one of"):
        FrankaArm("127.0.0.1", generation="panda")


# ------------------------------------------------- the command stream, offline, both streams


class _Raw:
    """A libfranka RobotState's fields, as either binding reports them."""

    def __init__(self, q: np.ndarray, mode: str) -> None:
        T = np.eye(4)
        T[:3, 3] = (0.3, 0.0, 0.5)
        self.q, self.dq, self.tau_J = list(q), [0.0] * 7, [0.0] * 7
        self.O_T_EE = T.reshape(-1, order="F").tolist()
        self.F_T_EE = np.eye(4).reshape(-1).tolist()
        self.robot_mode, self.current_errors = mode, []


class _Period:
    def to_sec(self) -> float:
        return 1e-3


class _Torques:
    def __init__(self, tau: list[float]) -> None:
        self.tau_J, self.motion_finished = list(tau), False


class _Fr3Active:
    """pylibfranka's ActiveControl: readOnce / writeOnce."""

    def __init__(self, log: list) -> None:
        self.log = log

    def readOnce(self):  # noqa: N802 - libfranka's name
        return _Raw(Q_READY, "RobotMode.Move"), _Period()

    def writeOnce(self, cmd: _Torques) -> None:  # noqa: N802 - libfranka's name
        self.log.append((cmd.tau_J, cmd.motion_finished))


class _FerRobot:
    """libfranka 0.9's Robot.control(callback): calls it until motion_finished."""

    def __init__(self, log: list) -> None:
        self.log = log

    def control(self, callback, limit_rate: bool, cutoff_frequency: float) -> None:
        assert limit_rate is False and cutoff_frequency >= 1000.0  # our own limit only
        while True:
            cmd = callback(_Raw(Q_READY, "RobotMode.kMove"), _Period())
            self.log.append((cmd.tau_J, cmd.motion_finished))
            if cmd.motion_finished:
                return


class _Model:
    def __init__(self) -> None:
        from dexlfd.robot import MujocoPandaModel

        self._m = MujocoPandaModel()

    def terms(self, q, dq):
        return self._m.terms(q, dq)

    def gravity(self, q):
        return self._m.terms(q, np.zeros(7)).g


class _Arm:
    host = "127.0.0.1"
    config = FrankaConfig()
    model = _Model()

    def __init__(self, stream) -> None:
        self.stream = stream

    def read_state(self):
        return state_from(_Raw(Q_READY, "RobotMode.Idle"))

    def torque_control(self):
        return self.stream

    def stop_quietly(self) -> None:
        pass


class _Step:
    """A law that asks for a torque step on joint 1 above gravity."""

    name = "step"
    needs_joint_reference = False

    def __init__(self, step_nm: float) -> None:
        self.step_nm = step_nm

    def init(self, robot_state, terms):
        return None

    def step(self, cs, robot_state, reference, terms):
        tau = terms.g.copy()
        tau[0] += self.step_nm
        return tau, cs

    def describe(self):
        return {"name": self.name}


@pytest.mark.parametrize("stream", ["fr3", "fer"])
def test_command_stream_limits(stream: str) -> None:
    log: list = []
    plf = SimpleNamespace(Torques=_Torques)
    if stream == "fr3":
        control = TorqueControl(_Fr3Active(log), plf, "127.0.0.1")
    else:
        control = CallbackTorqueControl(_FerRobot(log), plf, "127.0.0.1")
    n = 120
    # the reference is where the fake robot reports its TCP: no safety stop
    ref = Reference(np.array([0.3, 0.0, 0.5]), np.zeros(3), np.zeros(3), np.eye(3), np.zeros(3))
    law = _Step(200.0)
    rollout, stats = run_controller(_Arm(control), law, lambda i, t: ref, n, gripper_width=0.0)
    sent = np.array([tau for tau, _ in log])
    finished = [f for _, f in log]
    assert len(log) == n == stats.n_cycles == rollout.n_samples
    assert finished == [False] * (n - 1) + [True]  # motion_finished on the last command only
    step = FrankaConfig().max_torque_rate * 1e-3  # 1 N·m per 1 ms tick
    d = np.abs(np.diff(np.vstack([np.zeros(7), sent]), axis=0))
    assert d.max() <= step + 1e-9  # libfranka's 1000 N·m/s rate limit, from a zero start
    np.testing.assert_allclose(sent[:, 0], np.minimum(np.arange(1, n + 1) * step, TAU_MAX[0]))
    assert (np.abs(sent) <= TAU_MAX + 1e-9).all()
    # what is sent is the law's torque minus the robot's own gravity compensation
    np.testing.assert_allclose(sent[:, 1:], 0.0, atol=1e-12)
    np.testing.assert_allclose(rollout.extras["tau_sent"], sent, atol=0)


def test_fer_stream_has_no_read_write() -> None:
    control = CallbackTorqueControl(_FerRobot([]), SimpleNamespace(Torques=_Torques), "h")
    with pytest.raises(RobotConnectionError, match="callback-driven"):
        control.read()


def test_state_from_reads_both_bindings_modes() -> None:
    assert state_from(_Raw(Q_READY, "RobotMode.kReflex")).mode == "Reflex"
    assert state_from(_Raw(Q_READY, "RobotMode.Move")).mode == "Move"
    assert state_from(_Raw(Q_READY, "RobotMode.Move")).errors == "[]"
