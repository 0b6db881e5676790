"""The 1 kHz tick's laws and tests against plain reference computations of the same maths.

The loop's code is written for speed (ufuncs instead of ``np.clip``, a Cholesky solve
instead of an explicit inverse, values it has reused, plain floats); these references are
written straight from the equations (thesis §5.2, Eqs. (5.8)-(5.9), (5.16)-(5.26); the
momentum observer of De Luca and Mattone) with ``np.linalg.inv`` and quaternions, and must
agree on random states to round-off.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dexlfd.control import make_controller
from dexlfd.control.base import Reference, RobotState, saturate, spd_solve
from dexlfd.control.loop_config import LoopConfig
from dexlfd.control.safety import SafetyStop
from dexlfd.panda import DQ_MAX, Q_MAX, Q_MIN, Q_READY, TAU_MAX
from dexlfd.robot.actuation import rate_limit
from dexlfd.robot.friction import FrictionLaw, friction_torque

TOL = 1e-12  # [N·m] relative to the torque's size (at most TAU_MAX)


def _quat_error(R, R_d):
    """e_H = (η1η2 + ε1ᵀε2)(−η1ε2 + η2ε1 − S(ε1)ε2), Eq. (5.9), from quaternions."""
    x1, y1, z1, eta1 = Rotation.from_matrix(R).as_quat()
    x2, y2, z2, eta2 = Rotation.from_matrix(R_d).as_quat()
    eps1, eps2 = np.array([x1, y1, z1]), np.array([x2, y2, z2])
    return (eta1 * eta2 + eps1 @ eps2) * (-eta1 * eps2 + eta2 * eps1 - np.cross(eps1, eps2))


def _null(c, terms, q, dq, q_null):
    """(I − Jᵀ J̄ᵀ)(k_n (q_null − q) − d_n q̇), J̄ = M⁻¹Jᵀ Λ, Λ = (J M⁻¹ Jᵀ + 1e-6 I)⁻¹."""
    J, Minv = terms.J, np.linalg.inv(terms.M)
    Lam = np.linalg.inv(J @ Minv @ J.T + 1e-6 * np.eye(6))
    tau0 = c.k_null * (q_null - q) - c.d_null * dq
    return tau0 - J.T @ Lam @ J @ Minv @ tau0


def _moment(c, terms, dq, ref):
    w = terms.J[3:] @ dq
    return -c.K_H * _quat_error(terms.R, ref.R) - c.D_H * (w - ref.w)


def _ref_pd(c, terms, q, dq, ref, q_null):
    e = terms.p - ref.p
    F = -c.K_p * e - c.D_p * (terms.J[:3] @ dq - ref.v)
    tau = terms.J[:3].T @ F + terms.J[3:].T @ _moment(c, terms, dq, ref) + terms.h
    return np.clip(tau + _null(c, terms, q, dq, q_null), -TAU_MAX, TAU_MAX)


def _ref_sliding(c, terms, q, dq, ref, q_null, terminal, z=None, dt=0.0, dq_null=None):
    """Eq. (5.26) with Eq. (5.25) (``terminal``) or the linear surface; with ``z`` (∫ s dt
    before the tick) NTSM-PD-I's integral force; returns (τ, z after the tick)."""
    J, Minv = terms.J, np.linalg.inv(terms.M)
    e, de = terms.p - ref.p, J[:3] @ dq - ref.v
    if terminal:  # Eq. (5.25)
        s = e + c.beta * np.sign(de) * np.abs(de) ** c.alpha
        a_eq = -np.sign(de) * np.abs(de) ** (2 - c.alpha) / (c.alpha * c.beta)
    else:
        s, a_eq = e + c.beta * de, -de / c.beta
        if getattr(c, "surface", "beta") == "slope":  # Eq. (5.17): s = e/β + ė
            s = e / c.beta + de
    sat = np.tanh(c.k_s * s)
    m = _moment(c, terms, dq, ref)
    a = a_eq + ref.a - c.kappa * sat
    if c.decouple:
        a = a - J[:3] @ Minv @ J[3:].T @ m
    Mp = np.linalg.inv(J[:3] @ Minv @ J[:3].T + 1e-6 * np.eye(3))
    lam_f = {
        "force": c.lam * sat,
        "determinant": Mp @ (c.lam * sat) / np.linalg.det(Mp),
        "matrix": Mp @ np.linalg.inv(np.abs(Mp).T) @ (c.lam * sat),
    }[c.reading]
    F = Mp @ a - lam_f
    if z is not None:
        zmax = c.F_I_max / c.k_I
        z = np.clip(z + dt * s, -zmax, zmax)
        F = F - c.k_I * z
    null = _null(c, terms, q, dq, q_null)
    if dq_null is not None:  # the posture moves: d_n (q̇_null − q̇)
        null = null + _null_rate(c, terms, dq_null)
    tau = J[:3].T @ F + J[3:].T @ m + terms.h + null
    return np.clip(tau, -TAU_MAX, TAU_MAX), z


def _null_rate(c, terms, dq_null):
    """The projected d_n q̇_null of the null-space torque."""
    J, Minv = terms.J, np.linalg.inv(terms.M)
    Lam = np.linalg.inv(J @ Minv @ J.T + 1e-6 * np.eye(6))
    tau0 = c.d_null * dq_null
    return tau0 - J.T @ Lam @ J @ Minv @ tau0


def _states(model, rng, n):
    for _ in range(n):
        q = Q_READY + 0.3 * rng.standard_normal(7)
        dq = 0.5 * rng.standard_normal(7)
        p, R = model.tcp_pose(q)
        turn = Rotation.from_rotvec(0.1 * rng.standard_normal(3)).as_matrix()
        ref = Reference(
            p + 0.02 * rng.standard_normal(3), 0.2 * rng.standard_normal(3),
            rng.standard_normal(3), turn @ R, 0.3 * rng.standard_normal(3),
        )  # fmt: skip
        yield q, dq, ref


def _first_ticks(model, c, rng, n: int):
    """``c``'s first tick on ``n`` random states: (tau, terms, q, dq, ref, q_null) each."""
    for q, dq, ref in _states(model, rng, n):
        terms = model.terms(q, dq)
        q_null = q + 0.2 * rng.standard_normal(7)
        st = c.init(RobotState(0.0, q_null, np.zeros(7)), terms)  # q_null: the state's q
        tau, _ = c.step(st, RobotState(0.0, q, dq), ref, terms)
        yield tau, terms, q, dq, ref, q_null


@pytest.mark.parametrize("name", ["pd", "sm-pd", "ntsm-pd", "ntsm-pd-i"])
def test_law_equals_its_reference_computation(exact_model, name):
    rng = np.random.default_rng(7)
    c = make_controller(name)
    for tau, terms, q, dq, ref, q_null in _first_ticks(exact_model, c, rng, 25):
        if name == "pd":
            want = _ref_pd(c, terms, q, dq, ref, q_null)
        else:
            want, _ = _ref_sliding(c, terms, q, dq, ref, q_null, terminal=name != "sm-pd")
        assert np.abs(tau - want).max() <= TOL * np.abs(want).max()


@pytest.mark.parametrize(
    "name", ["sm-pd-det", "ntsm-pd-det", "sm-pd-matrix", "ntsm-pd-matrix", "sm-pd-slope"]
)
def test_readings_equal_their_reference_computation(exact_model, name):
    """Eq. (5.25)'s λ term read as a determinant or a matrix, Eq. (5.17) as printed."""
    rng = np.random.default_rng(13)
    c = make_controller(name)
    for tau, terms, q, dq, ref, q_null in _first_ticks(exact_model, c, rng, 10):
        want, _ = _ref_sliding(c, terms, q, dq, ref, q_null, terminal=name.startswith("ntsm"))
        assert np.abs(tau - want).max() <= TOL * np.abs(want).max()


def test_integral_law_over_ticks_equals_its_reference_computation(exact_model):
    """NTSM-PD-I: z += dt s with anti-windup at F_I_max / k_I, F −= k_I z, tick after tick,
    with a moving planned posture (q_null, q̇_null)."""
    rng = np.random.default_rng(14)
    c = make_controller("ntsm-pd-i")
    states = list(_states(exact_model, rng, 8))
    q0 = states[0][0]
    st = c.init(RobotState(0.0, q0, np.zeros(7)), exact_model.terms(q0, np.zeros(7)))
    z = np.zeros(3)
    for k, (q, dq, ref) in enumerate(states, start=1):
        q_null, dq_null = q + 0.1 * rng.standard_normal(7), rng.standard_normal(7)
        ref = Reference(ref.p, ref.v, ref.a, ref.R, ref.w, q_null=q_null, dq_null=dq_null)
        terms = exact_model.terms(q, dq)
        dt = 0.05 * k  # long enough for some axes to reach the bound
        tau, st = c.step(st, RobotState(st.t + dt, q, dq), ref, terms)
        want, z = _ref_sliding(c, terms, q, dq, ref, q_null, True, z, dt, dq_null)
        assert np.abs(st.z - z).max() <= 1e-15
        assert np.abs(tau - want).max() <= TOL * np.abs(want).max()
    assert np.isclose(np.abs(z).max(), c.F_I_max / c.k_I)  # the anti-windup bound was met


@pytest.mark.parametrize("name", ["sm-pd", "ntsm-pd", "ntsm-pd-i"])
def test_a_non_finite_state_gives_a_non_finite_torque(exact_model, name):
    """The loop stops on a non-finite torque: the saturation must not hide a NaN."""
    c = make_controller(name)
    q, dq, ref = next(_states(exact_model, np.random.default_rng(15), 1))
    terms = exact_model.terms(q, dq)
    st = c.init(RobotState(0.0, q, np.zeros(7)), terms)
    bad = dq.copy()
    bad[3] = np.nan
    tau, _ = c.step(st, RobotState(1e-3, q, bad), ref, terms)
    assert not np.isfinite(tau).all()


def test_observer_law_equals_its_reference_computation(exact_model):
    """NTSM-PD-DOB: p̂ and r = K_O (M q̇ − p̂) one tick after rest, τ = sat(τ_inner − r)."""
    rng = np.random.default_rng(8)
    c = make_controller("ntsm-pd-dob")
    for q, dq, ref in _states(exact_model, rng, 25):
        q0, dq0 = q + 0.01 * rng.standard_normal(7), dq + 0.1 * rng.standard_normal(7)
        t0 = exact_model.terms(q0, dq0)
        st = c.init(RobotState(0.0, q0, dq0), t0)
        terms = exact_model.terms(q, dq)
        dt = 1e-3
        tau, st1 = c.step(st, RobotState(dt, q, dq), ref, terms)
        Mdot_dq = (terms.M - t0.M) @ dq / dt
        p_hat = t0.M @ dq0 + dt * (t0.g - terms.h + Mdot_dq + 0.0)
        r = c.K_O * (terms.M @ dq - p_hat)
        inner, _ = _ref_sliding(c.inner, terms, q, dq, ref, q0, terminal=True)
        want = np.clip(inner - r, -TAU_MAX, TAU_MAX)
        assert np.abs(st1.r - r).max() <= TOL * max(1.0, np.abs(r).max())
        assert np.abs(tau - want).max() <= TOL * np.abs(want).max()


def test_spd_solve_equals_the_inverse():
    rng = np.random.default_rng(9)
    for n in (3, 6):
        B = rng.standard_normal((n, n + 1))
        A, y = B @ B.T + 1e-6 * np.eye(n), rng.standard_normal(n)
        keep = A.copy()
        x = spd_solve(A, y)
        np.testing.assert_allclose(x, np.linalg.inv(A) @ y, rtol=1e-10, atol=1e-12)
        np.testing.assert_array_equal(A, keep)  # not factorised in place


def test_clips_equal_np_clip():
    rng = np.random.default_rng(10)
    for _ in range(50):
        tau, prev = 120 * rng.standard_normal(7), 80 * rng.standard_normal(7)
        np.testing.assert_array_equal(saturate(tau), np.clip(tau, -TAU_MAX, TAU_MAX))
        want = np.clip(np.clip(tau, prev - 1.0, prev + 1.0), -TAU_MAX, TAU_MAX)
        np.testing.assert_array_equal(rate_limit(tau, prev, 1.0), want)
    assert np.isnan(saturate(np.full(7, np.nan))).all()  # a NaN stays visible to the loop


def test_friction_law_equals_the_identified_sigmoid():
    from dexlfd.panda import FRICTION_PHI1, FRICTION_PHI2, FRICTION_PHI3

    dq = np.random.default_rng(11).uniform(-2, 2, (20, 7))
    sig = 0.7 * FRICTION_PHI1 / (1 + np.exp(-FRICTION_PHI2 * (dq + FRICTION_PHI3)))
    want = sig - 0.7 * FRICTION_PHI1 / (1 + np.exp(-FRICTION_PHI2 * FRICTION_PHI3)) + 0.3 * dq
    np.testing.assert_allclose(FrictionLaw(0.7, 0.3)(dq), want, rtol=1e-14, atol=1e-14)
    np.testing.assert_array_equal(friction_torque(dq, 0.7, 0.3), FrictionLaw(0.7, 0.3)(dq))


def test_plant_kernels_equal_the_numpy_forms():
    """The simulated arm's rate limit (exact) and the plant's force: clip(τ) − τ_f(q̇)."""
    from dexlfd.robot.plant_kernels import plant_forces, rate_limit_into

    rng = np.random.default_rng(16)
    law = FrictionLaw(0.7, 0.3)
    for _ in range(50):
        tau, prev, dq = (
            120 * rng.standard_normal(7),
            80 * rng.standard_normal(7),
            rng.uniform(-2, 2, 7),
        )
        out = np.empty(7)
        rate_limit_into(tau, prev, 1.0, TAU_MAX, out)
        np.testing.assert_array_equal(out, rate_limit(tau, prev, 1.0))
        qfrc, ctrl = np.empty(7), np.array([0.02, 0.02])
        plant_forces(tau, dq, TAU_MAX, law.rows(), True, ctrl, 0.04, 1e-4, True, qfrc)
        want = np.clip(tau, -TAU_MAX, TAU_MAX) - law(dq)
        np.testing.assert_allclose(qfrc, want, rtol=1e-14, atol=1e-13)
        np.testing.assert_array_equal(ctrl, [0.0201, 0.0201])  # 0.1 mm towards 0.04 m
        plant_forces(tau, dq, TAU_MAX, law.rows(), False, ctrl, 0.0201, 1e-4, True, qfrc)
        np.testing.assert_array_equal(qfrc, np.clip(tau, -TAU_MAX, TAU_MAX))
        np.testing.assert_array_equal(ctrl, [0.0201, 0.0201])  # at its target: stays


def test_safety_check_equals_its_definition(exact_model):
    loop = LoopConfig()
    stop, lo, hi = (
        SafetyStop(loop),
        Q_MIN - loop.joint_limit_margin,
        Q_MAX + loop.joint_limit_margin,
    )
    rng = np.random.default_rng(12)
    for q, dq, ref in _states(exact_model, rng, 25):
        p, R = exact_model.tcp_pose(q)
        reason, err_r = stop.check(q, dq, p, R, ref)
        angle = np.arccos(np.clip(0.5 * (np.trace(R @ ref.R.T) - 1), -1, 1))
        assert err_r == pytest.approx(angle, abs=1e-12)
        err_p = float(np.linalg.norm(p - ref.p))
        bad_joint = bool(((q < lo) | (q > hi) | (np.abs(dq) > DQ_MAX)).any())
        assert (reason is not None) == (
            bad_joint or err_p > loop.max_position_error or angle > loop.max_orientation_error
        )


@pytest.mark.parametrize(
    ("j", "q_j", "dq_j", "words"),
    [
        (2, np.nan, 0.0, "non-finite joint state"),
        (3, 0.0, np.inf, "non-finite joint state"),
        (1, Q_MAX[1] + 0.1, 0.0, "joint 2 position"),
        (0, Q_MIN[0] - 0.1, 0.0, "joint 1 position"),
        (6, 0.0, -DQ_MAX[6] - 0.01, "joint 7 velocity"),
    ],
)
def test_safety_names_the_joint_that_stops(j, q_j, dq_j, words):
    stop = SafetyStop(LoopConfig(joint_limit_margin=0.0))
    q, dq = Q_READY.copy(), np.zeros(7)
    assert stop.joint_reason(q, dq) is None
    q[j] = q_j if q_j != 0.0 else q[j]
    dq[j] = dq_j
    reason = stop.joint_reason(q, dq)
    assert reason is not None and words in reason
    z, eye = np.zeros(3), np.eye(3)
    assert stop.check(q, dq, z, eye, Reference(z, z, z, eye, z)) == (reason, 0.0)  # the tick's
