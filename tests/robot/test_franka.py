"""Real-arm path: pylibfranka against the franky-sim Franka-protocol simulator on loopback.

The simulator runs in its own cached virtual environment (``.venv-franka-sim/``,
``make franka-sim``); the simulator tests skip with the reason when it cannot be
created. Every simulator is stopped by its PID in the fixture's finalizer.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from dexlfd.control.franka import run_controller, track_franka
from dexlfd.errors import DependencyNotInstalled, InvalidInput

pytestmark = pytest.mark.franka

ROOT = Path(__file__).resolve().parents[2]
SIM_ROOT = ROOT / ".venv-franka-sim"

# ---------------------------------------------------------------------------- no simulator


def test_parse_robot_url() -> None:
    from dexlfd.robot.url import parse_robot_url

    assert parse_robot_url("franka://172.16.0.2") == "172.16.0.2"
    assert parse_robot_url("franka://panda-1.lab/") == "panda-1.lab"
    for bad in ("mujoco", "franka://", "franka://bad host", "franka://1.2.3", "http://1.2.3.4"):
        with pytest.raises(InvalidInput, match="franka://HOST"):
            parse_robot_url(bad)
    from dexlfd.robot.franka import FrankaArm

    with pytest.raises(InvalidInput, match="host name"):
        FrankaArm("bad host")  # rejected before libfranka tries to resolve it


def test_missing_pylibfranka_names_the_pin(monkeypatch: pytest.MonkeyPatch) -> None:
    from dexlfd.robot.franka import FrankaArm
    from dexlfd.robot.libfranka import import_pylibfranka

    monkeypatch.setitem(sys.modules, "pylibfranka", None)
    with pytest.raises(DependencyNotInstalled, match=r"pylibfranka==0\.21\.3"):
        import_pylibfranka()
    with pytest.raises(DependencyNotInstalled, match=r"pip install 'dexlfd\[franka\]'"):
        FrankaArm("127.0.0.1", generation="fr3")


def test_rate_limit_closed_form() -> None:
    from dexlfd.panda import TAU_MAX
    from dexlfd.robot.actuation import rate_limit

    prev = np.array([0.0, 1.0, -1.0, 5.0, 0.0, 11.5, -11.5])
    want = np.array([3.0, 1.2, -4.0, 5.0, -0.5, 20.0, -20.0])
    out = rate_limit(want, prev, 1.0)
    np.testing.assert_allclose(out, [1.0, 1.2, -2.0, 5.0, -0.5, 12.0, -12.0], atol=1e-12)
    assert (np.abs(out) <= TAU_MAX).all()


def test_config_rejects_bad_values() -> None:
    from dexlfd.robot.franka import FrankaConfig

    with pytest.raises(InvalidInput, match="upper_torque_thresholds"):
        FrankaConfig(upper_torque_thresholds=(1.0,) * 6)
    with pytest.raises(InvalidInput, match="max_torque_rate"):
        FrankaConfig(max_torque_rate=0.0)
    with pytest.raises(InvalidInput, match="watchdog_s"):
        FrankaConfig(watchdog_s=0.0)


def test_nothing_listening_is_a_clear_error() -> None:
    from dexlfd.robot.franka import FrankaArm
    from dexlfd.robot.franka_sim import free_loopback_host
    from dexlfd.robot.libfranka import RobotConnectionError

    host = free_loopback_host(seed=4242)  # free ports: nothing serves there
    with pytest.raises(RobotConnectionError, match="simulator is not running"), FrankaArm(host):
        pass


_FAKE_OLD_ROBOT = textwrap.dedent(
    """
    import socket, struct, sys
    srv = socket.socket()
    srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    srv.bind((sys.argv[1], 1337)); srv.listen(1)
    print("READY", flush=True)
    srv.settimeout(20)
    c, _ = srv.accept()
    cmd, cid, size = struct.unpack("<III", c.recv(12))
    c.recv(size - 12)
    # Connect reply: status kIncompatibleLibraryVersion (1), server protocol version 9
    c.sendall(struct.pack("<III", 0, cid, 12 + 8) + struct.pack("<BH5x", 1, 9))
    c.recv(1)
    """
)


def test_protocol_version_mismatch_is_a_clear_error() -> None:
    from dexlfd.robot.franka import FrankaArm
    from dexlfd.robot.franka_sim import free_loopback_host
    from dexlfd.robot.libfranka import RobotConnectionError

    host = free_loopback_host(seed=777)
    proc = subprocess.Popen(
        [sys.executable, "-c", _FAKE_OLD_ROBOT, host], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "READY"
        with (
            pytest.raises(RobotConnectionError, match=r"speaks robot protocol 9, pylibfranka"),
            FrankaArm(host, generation="fr3"),
        ):
            pass
    finally:
        proc.kill()
        proc.wait()
        assert proc.stdout is not None
        proc.stdout.close()


def test_simulator_environment_failure_is_a_clear_error(tmp_path: Path) -> None:
    from dexlfd.robot.franka_sim import FrankaSimServer, SimulatorUnavailable, ensure_simulator_venv

    with pytest.raises(SimulatorUnavailable, match="cannot create"):
        ensure_simulator_venv(tmp_path, base_python=str(tmp_path / "no-python"))
    with pytest.raises(InvalidInput, match="loopback"):
        FrankaSimServer(tmp_path / "python", host="192.0.2.1")
    with pytest.raises(SimulatorUnavailable, match="does not exist"):
        FrankaSimServer(tmp_path / "python").start()


def test_split_at_grasp_events() -> None:
    from dexlfd.control.franka import split_at_grasp_events

    base = lift_plan(np.array([0.5, 0.0, 0.4]), np.diag([1.0, -1.0, -1.0]), T=1.0, hold=0.4)
    g = np.where((base.t >= 0.5) & (base.t < 1.0), 0.0, 0.08)
    # the plan's grasp schedule decides, not its opening
    plan = dataclasses.replace(base, gripper=np.full(base.t.shape, 0.05), grasp=g < 0.04)
    parts = split_at_grasp_events(plan)
    assert [e for _, e, _ in parts] == ["grasp", "open", None]
    np.testing.assert_allclose([s for _, _, s in parts], [0.0, 0.5, 1.0], atol=1e-12)
    for p, _, start in parts:
        assert p.t[0] == 0.0  # each on its own clock
        np.testing.assert_allclose(p.t + start, plan.t[np.isin(plan.t, p.t + start)], atol=1e-12)
    for (p, _, a), (q, _, b) in zip(parts[:-1], parts[1:], strict=True):
        assert a + p.t[-1] == pytest.approx(b)  # parts share their boundary sample
        np.testing.assert_array_equal(p.position[-1], q.position[0])
    assert sum(p.t.size for p, _, _ in parts) == plan.t.size + 2
    assert len(split_at_grasp_events(dataclasses.replace(base, grasp=None))) == 1  # no event
    # each part keeps its stretch of the plan's posture (the controllers' null-space reference)
    from dexlfd.panda import Q_READY

    posture = Q_READY + 0.1 * plan.t[:, None]
    with_posture = split_at_grasp_events(dataclasses.replace(plan, joint_posture=posture))
    for (p, _, a), (q, _, _) in zip(parts, with_posture, strict=True):
        k = int(np.argmin(np.abs(plan.t - a)))
        np.testing.assert_array_equal(q.joint_posture, posture[k : k + p.t.size])


def test_each_part_carries_the_plans_facts_on_its_own_clock() -> None:
    """Split at the grasp (0.5 s) and the release (1.0 s): each part is a plan by itself.

    Its typed facts are the whole plan's, restricted to it and shifted to its start:
    the spans where the arm holds its own posture (``hold_s``, read by the controllers),
    the grasp intervals, the slow-downs, the poses' times; the rest as they are.
    """
    from dexlfd.control.franka import split_at_grasp_events
    from dexlfd.control.posture_hold import PostureHold, hold_where_planned
    from dexlfd.io.plan_facts import (
        ArmPosture,
        GraspSchedule,
        Limits,
        Retimed,
        Slowdown,
        TaskPose,
        TimeScaling,
    )  # fmt: skip
    from dexlfd.panda import Q_READY

    base = lift_plan(np.array([0.5, 0.0, 0.4]), np.diag([1.0, -1.0, -1.0]), T=1.5, hold=0.4)
    closed = (base.t >= 0.5) & (base.t < 1.0)
    q = (0.0, 1.0, 0.0, 0.0)
    arm = ArmPosture(
        planned=True, margin=0.02, min_clearance=0.05, default_min_clearance=0.03,
        link="link 5", t_s=0.75, hold_s=((0.4, 0.6), (0.9, 1.2)),
    )  # fmt: skip
    plan = dataclasses.replace(
        base, grasp=closed, joint_posture=Q_READY + 0.1 * base.t[:, None], arm_posture=arm,
        grasp_schedule=GraspSchedule(method="model events", hold_s=0.2,
                                     intervals_s=((0.5, 1.0),)),
        pick=TaskPose((0.5, 0.0, 0.3), q, 0.0, 0.0, t=0.5),
        place=TaskPose((0.5, 0.0, 0.3), q, 0.0, 0.0, t=1.0),
        time_scaling=TimeScaling(slowdowns=(
            Slowdown((0.1, 0.3), 1.2, 0.05, stage="cartesian", part="reach"),
            Slowdown((0.6, 1.4), 1.5, 0.3, stage="joint"),
        ), added_s=0.35),
        retimed=Retimed(((0.1, 0.3), (0.6, 1.4)), (1.2, 1.5), 1.5, 1.15, 1.5),
        limits=Limits(peaks={"velocity": 0.3}), goal_error=0.001,
    )  # fmt: skip
    parts = split_at_grasp_events(plan)
    assert [round(s, 9) for _, _, s in parts] == [0.0, 0.5, 1.0]
    hold = [((0.4, 0.5),), ((0.0, 0.1), (0.4, 0.5)), ((0.0, 0.2),)]
    intervals = [(), ((0.0, 0.5),), ()]  # touching a part's end only: not its
    slowdowns = [[(0.1, 0.3)], [(0.1, 0.5)], [(0.0, 0.4)]]
    factors = [(1.2,), (1.5,), (1.5,)]
    for (part, _, start), h, iv, sd, f in zip(parts, hold, intervals, slowdowns, factors,
                                              strict=True):  # fmt: skip
        assert part.arm_posture is not None and part.grasp_schedule is not None
        np.testing.assert_allclose(part.arm_posture.hold_s, h, atol=1e-9)
        assert part.arm_posture.t_s == pytest.approx(0.75 - start)
        assert dataclasses.replace(part.arm_posture, hold_s=(), t_s=0.0) == dataclasses.replace(
            arm, hold_s=(), t_s=0.0
        )  # the rest of the fact as it was
        np.testing.assert_allclose(part.grasp_schedule.intervals_s, iv, atol=1e-9)
        assert part.grasp_schedule.hold_s == 0.2  # a duration, on no clock
        assert part.pick is not None and part.place is not None
        assert part.pick.t == pytest.approx(0.5 - start)
        assert part.place.t == pytest.approx(1.0 - start)
        assert part.time_scaling is not None and part.retimed is not None
        got = [s.t_s for s in part.time_scaling.slowdowns]
        np.testing.assert_allclose(got, sd, atol=1e-9)
        assert part.time_scaling.added_s == 0.35
        np.testing.assert_allclose(part.retimed.stretches_s, sd, atol=1e-9)
        assert part.retimed.factors == f
        assert part.limits == plan.limits and part.goal_error == plan.goal_error
        # the controller holds where the part says, on the part's own clock
        held = hold_where_planned(_NoLaw(), part)
        assert isinstance(held, PostureHold)
        np.testing.assert_allclose(held.windows, h, atol=1e-9)
    # a part without a span left is followed, not held
    tail = plan.part(int(np.searchsorted(plan.t, 1.25)), plan.t.size - 1)
    assert tail.arm_posture is not None and tail.arm_posture.hold_s == ()


class _NoLaw:
    """A stand-in law: :func:`hold_where_planned` only wraps it."""

    name = "none"
    needs_joint_reference = False


# ---------------------------------------------------------------------------- simulator


@pytest.fixture(scope="module")
def sim_python() -> Path:
    from dexlfd.robot.franka_sim import SimulatorUnavailable, ensure_simulator_venv

    try:
        return ensure_simulator_venv(SIM_ROOT)
    except SimulatorUnavailable as exc:
        pytest.skip(f"franky-sim environment unavailable (make franka-sim): {exc}")


# Every simulator runs in lock-step: the robot's clock advances only when our command for
# the last state has arrived (waiting up to this long, far beyond any scheduling stall), so
# a busy host slows these tests down but never changes robot time, states or outcomes.
# Times below are robot time (1 ms cycles), never wall-clock time.
LOCKSTEP_S = 60.0


def _server(python: Path, **kwargs):  # type: ignore[no-untyped-def]
    from dexlfd.robot.franka_sim import FrankaSimServer

    return FrankaSimServer(python, lockstep_s=LOCKSTEP_S, **kwargs).start()


@pytest.fixture(scope="module")
def sim(sim_python: Path):  # type: ignore[no-untyped-def]
    server = _server(sim_python)
    yield server
    server.stop()


@pytest.fixture(scope="module")
def arm(sim):  # type: ignore[no-untyped-def]
    from dexlfd.robot.franka import FrankaArm

    with FrankaArm(sim.host) as a:
        yield a


def lift_plan(p0: np.ndarray, R0: np.ndarray, dz: float = 0.08, T: float = 1.5, hold: float = 0.5):  # type: ignore[no-untyped-def]
    """A quintic (minimum-jerk) vertical lift by ``dz`` in ``T`` s, then a hold."""
    from dexlfd.io import Plan
    from dexlfd.rotations import quat_from_matrix

    t = np.arange(0.0, T + hold + 1e-9, 0.01)
    s = np.clip(t / T, 0.0, 1.0)
    n = t.size
    P = np.tile(p0, (n, 1))
    V, A = np.zeros((n, 3)), np.zeros((n, 3))
    P[:, 2] += dz * (10 * s**3 - 15 * s**4 + 6 * s**5)
    V[:, 2] = dz * (30 * s**2 - 60 * s**3 + 30 * s**4) / T
    A[:, 2] = dz * (60 * s - 180 * s**2 + 120 * s**3) / T**2
    return Plan(
        t=t,
        position=P,
        velocity=V,
        acceleration=A,
        quaternion=np.tile(quat_from_matrix(R0), (n, 1)),
        angular_velocity=np.zeros((n, 3)),
        gripper=np.full(n, 0.04),
    )


# ---------------------------------------------------------------------------- own simulators
# These start their own simulator; they run before the module's shared one exists, so
# no idle simulator takes a core beside them.
def test_reflex_reported_by_the_robot_stops_with_the_rollout(sim_python: Path) -> None:
    from dexlfd.control import make_controller
    from dexlfd.robot.franka import FrankaArm
    from dexlfd.robot.libfranka import RobotStopped

    server = _server(sim_python, reflex_after_s=0.25)
    try:
        with FrankaArm(server.host) as arm:
            s = arm.read_state()
            plan = lift_plan(s.O_T_EE[:3, 3], s.O_T_EE[:3, :3])
            with pytest.raises(RobotStopped, match="reflex") as info:
                track_franka(arm, plan, make_controller("ntsm-pd"))
            ro = info.value.rollout
            # the reflex comes after 250 commanded cycles of robot time, whatever the host
            assert ro is not None and ro.t[-1] == pytest.approx(0.25, abs=2.5e-3)
            assert "joint_reflex" in ro.stopped
            after = arm.read_state()
            assert after.mode == "Reflex" and "joint_reflex" in after.errors
            # recovered, the arm tracks again
            assert arm.recover().mode == "Idle"
            s = arm.read_state()
            plan = lift_plan(s.O_T_EE[:3, 3], s.O_T_EE[:3, :3], T=0.5, hold=0.1)
            ro2, _ = track_franka(arm, plan, make_controller("ntsm-pd"))
            assert ro2.stopped is None
    finally:
        server.stop()


def test_dropped_connection_mid_motion(sim_python: Path) -> None:
    from dexlfd.control import Reference, make_controller
    from dexlfd.robot.franka import FrankaArm
    from dexlfd.robot.libfranka import RobotStopped

    server = _server(sim_python)
    try:
        with FrankaArm(server.host) as arm:
            s = arm.read_state()
            p0, R0 = s.O_T_EE[:3, 3].copy(), s.O_T_EE[:3, :3].copy()

            def reference_at(i: int, t: float) -> Reference:
                if i == 200:
                    server.kill()  # the link dies mid-motion
                return Reference(p0, np.zeros(3), np.zeros(3), R0, np.zeros(3))

            with pytest.raises(RobotStopped, match="connection to .* lost") as info:
                run_controller(arm, make_controller("pd"), reference_at, 2000)
            ro = info.value.rollout
            assert ro is not None and 200 <= ro.t.size <= 202
    finally:
        server.stop()


def test_watchdog_stops_when_the_robot_clock_runs_on(sim_python: Path) -> None:
    """The robot's clock runs 400 ms past our last command (a stalled host on a real arm)."""
    from dexlfd.control import Reference, make_controller
    from dexlfd.robot.franka import FrankaArm, FrankaConfig
    from dexlfd.robot.libfranka import RobotStopped

    server = _server(sim_python, stall_after_cycles=100, stall_cycles=400)
    try:
        with FrankaArm(server.host, FrankaConfig(watchdog_s=0.25)) as arm:
            s = arm.read_state()
            p0, R0 = s.O_T_EE[:3, 3].copy(), s.O_T_EE[:3, :3].copy()

            def reference_at(i: int, t: float) -> Reference:
                return Reference(p0, np.zeros(3), np.zeros(3), R0, np.zeros(3))

            with pytest.raises(RobotStopped, match=r"watchdog: no robot state for 40\d ms") as info:
                run_controller(arm, make_controller("pd"), reference_at, 1000)
            ro = info.value.rollout
            # 100 commanded cycles (t = 0 .. 0.099 s), then the state 401 ms later
            assert ro is not None and ro.t.size == 101
            assert ro.t[-1] == pytest.approx(0.099 + 0.401, abs=1.5e-3)
            assert "watchdog" in ro.stopped
            # the torque sent on the stop cycle ramps down (rate limit), never jumps
            sent = ro.extras["tau_sent"]
            assert (np.abs(np.diff(sent, axis=0)) <= 1.0 + 1e-9).all()
            assert arm.read_state().mode == "Idle"
    finally:
        server.stop()


def test_cli_simulate_on_the_arm(sim_python: Path, tmp_path: Path) -> None:
    from dexlfd.cli import main
    from dexlfd.io import load_rollout, save_plan
    from dexlfd.robot.franka import FrankaArm

    server = _server(sim_python)  # its own simulator: one client per Franka
    try:
        with FrankaArm(server.host) as arm:
            s = arm.read_state()
        plan = lift_plan(s.O_T_EE[:3, 3], s.O_T_EE[:3, :3], T=0.8, hold=0.2)
        plan_path = save_plan(tmp_path / "plan.npz", plan)
        out, png = tmp_path / "rollout.npz", tmp_path / "r.png"
        args = ["simulate", str(plan_path), "--robot", server.url, "-o", str(out)]
        assert main([*args, "--plot", str(png)]) == 0
        ro = load_rollout(out)
        assert ro.meta["robot"] == server.url and 1.0 - 1e-9 <= ro.t[-1] < 1.1
        assert png.stat().st_size > 0
    finally:
        server.stop()
    bad = ["simulate", str(plan_path), "--robot", "franka://no host", "-o", str(out)]
    assert main(bad) == 1


def test_cli_writes_the_partial_rollout_on_a_reflex(sim_python: Path, tmp_path: Path) -> None:
    from dexlfd.cli import main
    from dexlfd.io import load_rollout, save_plan
    from dexlfd.robot.franka import FrankaArm

    server = _server(sim_python, reflex_after_s=0.3)
    try:
        with FrankaArm(server.host) as arm:
            s = arm.read_state()
        plan_path = save_plan(tmp_path / "plan.npz", lift_plan(s.O_T_EE[:3, 3], s.O_T_EE[:3, :3]))
        out = tmp_path / "partial.npz"
        assert main(["simulate", str(plan_path), "--robot", server.url, "-o", str(out)]) == 1
        ro = load_rollout(out)
        assert "reflex" in ro.stopped and ro.t[-1] == pytest.approx(0.3, abs=2.5e-3)
    finally:
        server.stop()


@pytest.mark.slow  # six 2-4 s lifts on fresh simulators (~25 s)
def test_cli_payload_study_over_the_protocol(sim_python: Path, tmp_path: Path) -> None:
    import json

    from dexlfd.cli import main

    rows_path = tmp_path / "rows.json"
    args = ["experiment", "payload", "--robot", "franky-sim", "--sim-root", str(SIM_ROOT),
            "--controllers", "pd", "--duration-s", "4", "--sim-lockstep-s", str(LOCKSTEP_S),
            "-o", str(tmp_path), "--json", str(rows_path)]  # fmt: skip
    assert main(args) == 0
    rows = {r["payload_kg"]: r for r in json.loads(rows_path.read_text())}
    assert set(rows) == {0.45, 1.2} and not any("stopped" in r for r in rows.values())
    # Cartesian PD sags by about weight / K_p (9.81 m / 600 N/m per kg); the FR3's joint
    # friction and the carried-window average make it 60-110 % of that here
    for m, r in rows.items():
        closed_form = m * 9.81 / 600.0
        assert 0.6 * closed_form < -r["sag_m"] < 1.1 * closed_form, (m, r["sag_m"])
    assert rows[1.2]["e_ob_m"] > rows[0.45]["e_ob_m"] > rows[0.45]["e_nob_m"]
    assert (tmp_path / "payload_lift_z_franka.png").stat().st_size > 0
    # a 2 s lift is too fast for the wrist: the safety stop ends every run, rows say so
    args[args.index("4")] = "2"
    assert main(args) == 0
    stopped = json.loads(rows_path.read_text())
    assert len(stopped) == 2 and all("joint" in r["stopped"] for r in stopped)


# ---------------------------------------------------------------------------- the shared simulator


def test_simulator_confined_to_loopback(sim) -> None:  # type: ignore[no-untyped-def]
    out = subprocess.run(["ss", "-H", "-tuanp"], capture_output=True, text=True, check=False)
    if out.returncode != 0:
        pytest.skip("ss not available")
    mine = [ln for ln in out.stdout.splitlines() if f"pid={sim.pid}," in ln]
    assert mine, "the simulator has no sockets?"
    for line in mine:
        local = line.split()[4]
        assert local.startswith(sim.host + ":"), line


def test_model_terms_match_the_panda_model(arm) -> None:  # type: ignore[no-untyped-def]
    """libfranka's FR3 Jacobian/J̇q̇ = our Panda model's (same DH kinematics); M SPD."""
    from dexlfd.robot.robot_model import MujocoPandaModel

    ours = MujocoPandaModel()
    rng = np.random.default_rng(42)
    state = arm.read_state()
    p, R = arm.model.tcp_pose(state.q)
    # the simulator's own (Pinocchio) O_T_EE: agrees to ~7 µm while the arm settles
    np.testing.assert_allclose(p, state.O_T_EE[:3, 3], atol=5e-5)
    np.testing.assert_allclose(R, state.O_T_EE[:3, :3], atol=5e-5)
    for _ in range(3):
        q = state.q + rng.uniform(-0.3, 0.3, 7)
        dq = rng.uniform(-0.5, 0.5, 7)
        mine = arm.model.terms(q, dq)
        ref = ours.terms(q, dq)
        np.testing.assert_allclose(mine.J, ref.J, atol=1e-6)
        np.testing.assert_allclose(mine.p, ref.p, atol=1e-6)
        # what the inverse kinematics iterates on: the pose and the Jacobian together
        pose_jac = arm.model.tcp_pose_jacobian(q)
        for a, b in zip(pose_jac, (*arm.model.tcp_pose(q), arm.model.tcp_jacobian(q)), strict=True):
            np.testing.assert_array_equal(a, b)
        # central difference, step 1e-6 rad: error ~1e-6 relative
        np.testing.assert_allclose(mine.Jdq, ref.Jdq, atol=1e-5)
        np.testing.assert_allclose(mine.M, mine.M.T, atol=1e-12)
        assert np.linalg.eigvalsh(mine.M).min() > 0
        # C(q, q̇)q̇ is quadratic in q̇ and vanishes at rest (libfranka's coriolis)
        c1 = mine.h - mine.g
        c2 = arm.model.terms(q, 2.0 * dq)
        np.testing.assert_allclose(c2.h - c2.g, 4.0 * c1, rtol=1e-9, atol=1e-9)
        rest = arm.model.terms(q, np.zeros(7))
        np.testing.assert_allclose(rest.h, rest.g, atol=1e-12)
        np.testing.assert_allclose(rest.g, mine.g, atol=1e-12)  # G depends on q only


def test_set_load_changes_gravity_by_the_point_mass_term(arm) -> None:  # type: ignore[no-untyped-def]
    """G(q) with a point load m at the TCP = G(q) + J_p(q)ᵀ (0, 0, m·9.81)."""
    q = arm.read_state().q
    zero = np.zeros(7)
    g0 = arm.model.terms(q, zero).g
    m = 1.2
    arm.set_load(m, (0.0, 0.0, 0.1034))
    try:
        g1 = arm.model.terms(q, zero).g
        J = arm.model.tcp_jacobian(q)
        np.testing.assert_allclose(g1 - g0, J[:3].T @ np.array([0.0, 0.0, m * 9.81]), atol=1e-4)
    finally:
        arm.set_load(0.0)
    with pytest.raises(InvalidInput, match="mass"):
        arm.set_load(5.0)


@pytest.mark.parametrize("name", ["ntsm-pd", "pd"])
def test_tracks_a_lift_over_the_protocol(arm, name: str) -> None:  # type: ignore[no-untyped-def]
    from dexlfd.control import make_controller

    start = arm.read_state()
    plan = lift_plan(start.O_T_EE[:3, 3], start.O_T_EE[:3, :3])
    rollout, stats = track_franka(arm, plan, make_controller(name))
    n = rollout.t.size
    assert rollout.stopped is None
    # lock-step: one state per command (robot time advances 1 ms per cycle); only a
    # host too slow to send its first command within 0.5 s lets the robot's clock
    # run on before cycle 1 (the simulator holds the physics then); the motion ends
    # at the plan's end, 2.0 s of robot time
    per = rollout.extras["period_s"]
    np.testing.assert_allclose(per[2:], 1e-3, atol=1e-12)
    assert stats.missed_cycles == round(per[1] * 1e3) - 1 and n == 2001 - stats.missed_cycles
    assert rollout.t[-1] == pytest.approx(2.0, abs=1e-9)
    err = rollout.ee_position - rollout.ref_position
    rmse = np.sqrt(np.mean(np.sum(err**2, axis=1)))
    # the FR3 plant has joint friction (frictionloss 1.1 N·m), unmodelled fingers and
    # a MuJoCo-vs-Pinocchio model gap: errors of a few mm (measured 4-14 mm)
    assert rmse < 0.03, rmse
    assert rollout.ee_position[-1, 2] - rollout.ee_position[0, 2] > 0.06  # it lifted
    # the wall rate and compute time depend on the host: benchmarks/bench_franka.py
    assert stats.n_cycles == n
    np.testing.assert_allclose(
        np.linalg.norm(rollout.ee_quaternion, axis=1), 1.0, atol=1e-9
    )  # unit quaternions
    sent = rollout.extras["tau_sent"]
    assert (np.abs(np.diff(sent, axis=0)) <= 1.0 + 1e-9).all()  # ≤ 1000 N·m/s
    assert rollout.meta["robot"] == f"franka://{arm.host}"


def test_our_safety_stop_keeps_the_rollout_and_stops(arm) -> None:  # type: ignore[no-untyped-def]
    from dexlfd.control import LoopConfig, Reference, make_controller
    from dexlfd.robot.libfranka import RobotStopped

    s = arm.read_state()
    p0, R0 = s.O_T_EE[:3, 3].copy(), s.O_T_EE[:3, :3].copy()

    def reference_at(i: int, t: float) -> Reference:
        jump = np.array([0.0, 0.0, 0.2]) if i >= 150 else np.zeros(3)
        return Reference(p0 + jump, np.zeros(3), np.zeros(3), R0, np.zeros(3))

    with pytest.raises(RobotStopped, match="TCP position error") as info:
        run_controller(
            arm,
            make_controller("ntsm-pd"),
            reference_at,
            1000,
            loop=LoopConfig(),
        )
    ro = info.value.rollout
    assert ro is not None and ro.t.size == 151
    assert "TCP position error" in ro.stopped
    # the arm is usable again: idle and holding where it was
    after = arm.read_state()
    assert after.mode == "Idle"
    assert np.linalg.norm(after.O_T_EE[:3, 3] - p0) < 0.01


def test_gripper_homing_move_grasp(arm) -> None:  # type: ignore[no-untyped-def]
    g = arm.gripper
    assert g.homing()
    assert g.move(0.06)
    assert g.width() == pytest.approx(0.06, abs=0.003)
    assert g.grasp(0.0, force=40.0)
    assert g.width() < 0.01 and g.is_grasped()
    assert g.move(0.08)
    with pytest.raises(InvalidInput, match="width"):
        g.move(0.2)


def test_plan_far_from_the_tcp_is_refused_or_approached(arm) -> None:  # type: ignore[no-untyped-def]
    from dexlfd.control import make_controller

    s = arm.read_state()
    p0, R0 = s.O_T_EE[:3, 3].copy(), s.O_T_EE[:3, :3].copy()
    plan = lift_plan(p0 + np.array([0.0, 0.04, -0.03]), R0, dz=0.02, T=0.5, hold=0.2)
    with pytest.raises(InvalidInput, match="plan starts .* mm from the arm's TCP"):
        track_franka(arm, plan, make_controller("ntsm-pd"))
    rollout, _ = track_franka(arm, plan, make_controller("ntsm-pd"), approach=True)
    assert np.linalg.norm(rollout.ee_position[0] - plan.position[0]) < 0.01
    assert np.linalg.norm(rollout.ee_position[-1] - plan.position[-1]) < 0.02


def test_lockstep_a_slow_host_changes_nothing(arm) -> None:  # type: ignore[no-untyped-def]
    """A policy that stalls the host for 0.3 s: the robot's clock waits, no cycle is missed."""
    import time

    from dexlfd.control import Reference, make_controller

    s = arm.read_state()
    p0, R0 = s.O_T_EE[:3, 3].copy(), s.O_T_EE[:3, :3].copy()

    def reference_at(i: int, t: float) -> Reference:
        if i == 100:
            time.sleep(0.3)  # the host is busy with something else
        return Reference(p0, np.zeros(3), np.zeros(3), R0, np.zeros(3))

    rollout, stats = run_controller(arm, make_controller("pd"), reference_at, 300)
    assert rollout.stopped is None
    # 1 ms of robot time per cycle, across the 0.3 s stall at cycle 100 too (only a start
    # slower than 0.5 s could hold the clock before cycle 1: see the lift test)
    per = rollout.extras["period_s"]
    np.testing.assert_allclose(per[2:], 1e-3, atol=1e-12)
    assert stats.missed_cycles == round(per[1] * 1e3) - 1


class _NanAfter:
    """A law that turns non-finite after ``k`` steps (a diverging controller)."""

    name = "nan-after"
    needs_joint_reference = False

    def __init__(self, k: int) -> None:
        self.k = k

    def init(self, robot_state, terms):  # type: ignore[no-untyped-def]
        return 0

    def step(self, n, robot_state, reference, terms):  # type: ignore[no-untyped-def]
        tau = terms.g.copy() if n < self.k else np.full(7, np.nan)
        return tau, n + 1

    def describe(self):  # type: ignore[no-untyped-def]
        return {"name": self.name}


def test_non_finite_torque_is_never_sent(arm) -> None:  # type: ignore[no-untyped-def]
    from dexlfd.control import Reference
    from dexlfd.robot.libfranka import RobotStopped

    s = arm.read_state()
    ref = Reference(s.O_T_EE[:3, 3], np.zeros(3), np.zeros(3), s.O_T_EE[:3, :3], np.zeros(3))
    with pytest.raises(RobotStopped, match="non-finite") as info:
        # the warm-up call is step 0, the loop's first is step 1 (init resets n)
        run_controller(arm, _NanAfter(50), lambda i, t: ref, 500)
    ro = info.value.rollout
    assert ro is not None and ro.t.size == 51
    assert np.isfinite(ro.extras["tau_sent"]).all()
    np.testing.assert_allclose(ro.extras["tau_sent"][:50], 0.0, atol=1.0)  # τ − G ≈ 0


def test_plan_gripper_channel_is_executed(arm) -> None:  # type: ignore[no-untyped-def]
    from dexlfd.control import make_controller

    arm.gripper.move(0.08)
    s = arm.read_state()
    base = lift_plan(s.O_T_EE[:3, 3], s.O_T_EE[:3, :3], dz=0.04, T=1.0, hold=0.3)
    plan = dataclasses.replace(base, gripper=np.where(base.t >= 0.4, 0.0, 0.08))
    rollout, stats = track_franka(arm, plan, make_controller("ntsm-pd"), gripper=True)
    assert arm.gripper.is_grasped()
    assert np.all(np.diff(rollout.t) > 0) and 1.3 - 1e-9 <= rollout.t[-1] < 1.4
    before, after = rollout.gripper[rollout.t < 0.39], rollout.gripper[rollout.t > 0.41]
    assert before.min() > 0.07 and after.max() < 0.01  # the hand closed at t = 0.4 s
    assert rollout.meta["gripper_events"] == 1 and stats.n_cycles == rollout.t.size + 1
    arm.gripper.move(0.08)


class _NullSpy:
    """A law (``inner``'s torque) that records each tick's time, joints and null-space reference."""

    def __init__(self, inner) -> None:  # type: ignore[no-untyped-def]
        self.inner, self.name = inner, inner.name
        self.needs_joint_reference = inner.needs_joint_reference
        self.seen: list[tuple[float, np.ndarray, np.ndarray | None]] = []

    def init(self, robot_state, terms):  # type: ignore[no-untyped-def]
        return self.inner.init(robot_state, terms)

    def step(self, cs, robot_state, reference, terms):  # type: ignore[no-untyped-def]
        qn = None if reference.q_null is None else reference.q_null.copy()
        self.seen.append((robot_state.t, robot_state.q.copy(), qn))
        return self.inner.step(cs, robot_state, reference, terms)

    def describe(self):  # type: ignore[no-untyped-def]
        return self.inner.describe()


@pytest.mark.parametrize("gripper", [False, True])
def test_the_arm_holds_its_posture_where_the_plan_says(arm, gripper: bool) -> None:  # type: ignore[no-untyped-def]
    """As in simulation: within ``arm_posture.hold_s`` the null-space reference is the arm's
    posture on entering, then blends back to the plan's; with the gripper each part runs
    on its own clock from 0, a plan by itself with the plan's spans shifted to its start."""
    from dexlfd.control import make_controller
    from dexlfd.io.plan_facts import ArmPosture
    from dexlfd.robot.posture_hold import BLEND_S

    arm.gripper.move(0.08)
    s = arm.read_state()
    base = lift_plan(s.O_T_EE[:3, 3], s.O_T_EE[:3, :3], dz=0.03, T=1.0, hold=1.0)
    posture = np.asarray(s.q) + 0.02 * base.t[:, None]  # the plan's posture, 0.02 rad/s
    hold = ((0.2, 0.6), (1.8, 1.9))  # round the grasp at 0.4 s, and one within part 2
    plan = dataclasses.replace(
        base, gripper=np.where(base.t >= 0.4, 0.0, 0.08), joint_posture=posture,
        arm_posture=ArmPosture(planned=True, margin=0.02, min_clearance=1.0,
                               default_min_clearance=1.0, hold_s=hold),
    )  # fmt: skip
    spy = _NullSpy(make_controller("ntsm-pd"))
    rollout, _ = track_franka(arm, plan, spy, gripper=gripper)
    assert rollout.stopped is None
    # each part's ticks (its clock restarts at 0; its first call is the warm-up), in plan time
    t = np.array([x[0] for x in spy.seen])
    parts = np.split(np.arange(t.size), np.flatnonzero(np.diff(t) < 0) + 1)
    assert len(parts) == (2 if gripper else 1)
    planned = held = 0
    for part, start in zip(parts, [0.0, 0.4], strict=False):
        entry: np.ndarray | None = None
        for i in part[1:]:
            tp, q_null = t[i] + start, spy.seen[i][2]
            assert q_null is not None  # every part follows the plan's posture
            if any(a <= tp <= b for a, b in hold):
                if entry is None:  # the arm's own posture on entering (this tick or just before)
                    entry = q_null
                    assert any(np.array_equal(q_null, spy.seen[j][1]) for j in range(i - 3, i + 1))
                if min(min(abs(tp - a), abs(tp - b)) for a, b in hold) > 2e-3:  # not on an edge
                    np.testing.assert_array_equal(q_null, entry)  # held still
                    held += 1
            else:
                entry = None
                if all(tp > b + BLEND_S + 2e-3 or tp < a - 2e-3 for a, b in hold):
                    np.testing.assert_allclose(q_null, s.q + 0.02 * tp, atol=1e-9)
                    planned += 1
    assert held > 400 and planned > 300
    # the last part's spans: on its clock, cut to it (the first began before it)
    last = [[0.0, 0.2], [1.4, 1.5]] if gripper else [list(w) for w in hold]
    np.testing.assert_allclose(rollout.meta["controller"]["posture_hold_s"], last, atol=1e-12)
    if gripper:
        arm.gripper.move(0.08)


def test_state_listener_sees_every_cycle_and_the_ros2_rate(arm) -> None:  # type: ignore[no-untyped-def]
    """``FrankaArm.state_listener`` (the ROS 2 joint states of a real run) gets every cycle."""
    from dexlfd._commands._ros2 import arm_state_listener
    from dexlfd.control import Reference, make_controller

    s = arm.read_state()
    p0, R0 = s.O_T_EE[:3, 3].copy(), s.O_T_EE[:3, :3].copy()
    seen: list[tuple[float, np.ndarray]] = []
    published: list[float] = []
    at_rate = arm_state_listener(
        type("Pub", (), {"publish_state": lambda self, t, q, dq, tau: published.append(t)})(),
        100.0,
    )

    def listener(t: float, state) -> None:  # type: ignore[no-untyped-def]
        seen.append((t, np.array(state.q)))
        at_rate(t, state)

    arm.state_listener = listener
    try:
        rollout, _ = run_controller(
            arm, make_controller("pd"),
            lambda i, t: Reference(p0, np.zeros(3), np.zeros(3), R0, np.zeros(3)), 250,
        )  # fmt: skip
    finally:
        arm.state_listener = None
    assert len(seen) == rollout.n_samples
    np.testing.assert_allclose([t for t, _ in seen], rollout.t, atol=0)
    np.testing.assert_allclose(seen[-1][1], rollout.q[-1], atol=0)
    # 100 Hz of robot time: one every 10 ms from t = 0
    assert np.diff(published).min() >= 0.01 - 1e-9
    assert len(published) == pytest.approx(rollout.t[-1] / 0.01 + 1, abs=1)
