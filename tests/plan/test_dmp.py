from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dexlfd.datasets import PickPlaceConfig, pick_place_reference
from dexlfd.errors import InvalidInput
from dexlfd.plan import DmpConfig, coupling_response, fit_dmp, forcing, phase, rollout_dmp
from dexlfd.plan.dmp import _forcing_target

T = 8.0
THESIS_STARTS = np.array([[0.37, -0.34, 0.22], [0.50, -0.25, 0.21], [0.55, -0.34, 0.28]])
THESIS_GOALS = np.array([[0.51, 0.11, 0.31], [0.50, 0.19, 0.30], [0.50, 0.28, 0.32]])


def _demo(n: int = 1000) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, T, n)
    pos, _q, _g = pick_place_reference(t / T, PickPlaceConfig())
    return t, pos


def _dtw(a: np.ndarray, b: np.ndarray) -> float:
    """Plain O(nm) DTW with Euclidean cost, mean cost per step of the path."""
    n, m = len(a), len(b)
    cost = np.linalg.norm(a[:, None] - b[None], axis=2)
    acc = np.full((n + 1, m + 1), np.inf)
    acc[0, 0] = 0.0
    steps = np.zeros((n + 1, m + 1))
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            k = np.argmin([acc[i - 1, j - 1], acc[i - 1, j], acc[i, j - 1]])
            prev = [(i - 1, j - 1), (i - 1, j), (i, j - 1)][k]
            acc[i, j] = cost[i - 1, j - 1] + acc[prev]
            steps[i, j] = steps[prev] + 1
    return float(acc[n, m] / steps[n, m])


def _normalised_shape(x: np.ndarray, n: int = 60) -> np.ndarray:
    """Remove the straight start-goal line, resample: what the DMP should keep."""
    u = np.linspace(0.0, 1.0, len(x))[:, None]
    shape = x - (x[0] + u * (x[-1] - x[0]))
    idx = np.linspace(0, len(x) - 1, n).round().astype(int)
    return shape[idx]


def test_zero_forcing_reaches_goal() -> None:
    """f = 0: x'' + Db x' + Kb x = Kb g - Kb (g - x0) exp(-a t); closed form, critically damped."""
    t, pos = _demo()
    dmp = fit_dmp(t, pos)
    dmp0 = type(dmp)(
        dmp.config, np.zeros_like(dmp.weights), dmp.x0, dmp.g, np.zeros(3), T, dmp.fit_residual
    )
    g = np.array([0.5, 0.1, 0.3])
    x0 = dmp.x0
    r = rollout_dmp(dmp0, g=g, n_steps=2001)
    c = dmp.config
    a, w = c.alpha_s, c.D_bar / 2
    A = c.K_bar * (g - x0) / (a * a - c.D_bar * a + c.K_bar)
    C1 = x0 - g + A
    C2 = w * C1 - a * A
    tb = np.linspace(0, 1, 2001)[:, None]
    exact = g - A * np.exp(-a * tb) + (C1 + C2 * tb) * np.exp(-w * tb)
    # exact transition; the only error is the linear hold of exp(-a t) over dt = 5e-4
    np.testing.assert_allclose(r.x, exact, atol=1e-6)
    # at t = T the remaining error is A exp(-a): 0.26 % of the start-goal distance
    assert np.all(np.abs(r.x[-1] - g) <= 3e-3 * np.abs(g - x0) + 1e-12)


def test_rollout_matches_ode_solver() -> None:
    """The exact-transition rollout equals an adaptive RK45 solve of the continuous ODE."""
    t, pos = _demo(400)
    dmp = fit_dmp(t, pos[:, 2:], DmpConfig(n_basis=30))
    x0, g = np.array([0.2]), np.array([0.35])
    r = rollout_dmp(dmp, x0=x0, g=g, n_steps=4001)
    c = dmp.config

    def rhs(tb: float, z: np.ndarray) -> np.ndarray:
        s = phase(np.array([tb]), c.alpha_s)
        f = forcing(dmp, s)[0]
        vd = c.K_bar * (g - z[0]) - c.D_bar * z[1] - c.K_bar * (g - x0) * s + c.K_bar * f
        return np.array([z[1], vd[0]])

    sol = solve_ivp(
        rhs, (0, 1), [x0[0], dmp.v0[0]], t_eval=np.linspace(0, 1, 4001), rtol=1e-10, atol=1e-12
    )
    # first-order hold of the forcing over dt = 2.5e-4: error O(dt^2) ~ 1e-7 m
    np.testing.assert_allclose(r.x[:, 0], sol.y[0], atol=1e-6)
    np.testing.assert_allclose(r.xd[:, 0] * T, sol.y[1], atol=1e-4)


def test_reproduction_within_fit_bound() -> None:
    """Reproduction error <= the fit residual filtered by the critically damped DMP.

    e'' + Db e' + Kb e = Kb (f_fit - f_target), e(0) = e'(0) = 0; the impulse response
    Kb t exp(-w t) is positive with unit integral, so |e(t)| <= (h * |df|)(t).
    """
    t, pos = _demo()
    dmp = fit_dmp(t, pos)
    r = rollout_dmp(dmp, n_steps=len(t))
    tb = t / T
    f_t, _ = _forcing_target(tb, pos, pos[-1], pos[0], dmp.config)
    df = np.abs(forcing(dmp, phase(tb, dmp.config.alpha_s)) - f_t)
    w = np.sqrt(dmp.config.K_bar)
    kernel = dmp.config.K_bar * tb * np.exp(-w * tb) * (tb[1] - tb[0])
    bound = np.stack([np.convolve(df[:, j], kernel)[: len(tb)] for j in range(3)], axis=1)
    err = np.abs(r.x - pos)
    assert np.all(err <= bound + 2e-4)  # + derivative estimates on the 1000-sample grid
    assert err.max() < 2e-3  # 100 basis functions on this 8 s path: below 2 mm


def test_initial_velocity_is_kept() -> None:
    """A demonstration that starts moving: the first second is reproduced."""
    t = np.linspace(0.0, 5.0, 500)
    x = (0.1 * t + 0.05 * np.sin(t))[:, None]  # 0.15 m/s at t = 0
    dmp = fit_dmp(t, x)
    r = rollout_dmp(dmp, n_steps=500)
    first = t <= 1.0
    assert np.abs(r.x[first, 0] - x[first, 0]).max() < 5e-4
    np.testing.assert_allclose(r.xd[0, 0], 0.15, rtol=1e-3)
    rest = rollout_dmp(dmp, n_steps=500, v0=np.zeros(1))
    assert (
        np.abs(rest.x[first, 0] - x[first, 0]).max()
        > 10 * np.abs(r.x[first, 0] - x[first, 0]).max()
    )


@pytest.mark.parametrize("k", range(3))
def test_thesis_new_starts_and_goals(k: int) -> None:
    """Section 5.3.1: three new starts and goals, reached within 1 mm, shape kept."""
    t, pos = _demo()
    dmp = fit_dmp(t, pos)
    r = rollout_dmp(dmp, x0=THESIS_STARTS[k], g=THESIS_GOALS[k], n_steps=8001)
    assert np.linalg.norm(r.x[-1] - THESIS_GOALS[k]) < 1e-3
    assert np.linalg.norm(r.x[0] - THESIS_STARTS[k]) < 1e-12
    shape_demo = _normalised_shape(pos)
    shape_new = _normalised_shape(r.x)
    d = _dtw(shape_demo, shape_new)
    # mean DTW cost per step [m] after removing the start-goal line: under 17 % of
    # the 0.3 m lift over the cup (the new start/goal moves the pick and place too)
    assert d < 0.05
    corr = np.corrcoef(shape_demo[:, 2], shape_new[:, 2])[0, 1]
    assert corr > 0.98


def test_modified_keeps_shape_under_sign_flip_original_mirrors() -> None:
    t, pos = _demo()
    x = pos[:, 1:3]  # y goes -0.3 -> 0.3, z starts and ends at the same height
    x = x + np.array([0.0, 0.05]) * (t / T)[:, None]  # give z a small net rise
    mod = fit_dmp(t, x, DmpConfig(variant="modified"))
    org = fit_dmp(t, x, DmpConfig(variant="original"))
    x0, g = x[0].copy(), x[-1].copy()
    flipped_g = g.copy()
    flipped_g[1] = x0[1] - 0.05  # z now ends 5 cm BELOW its start: g - x0 changes sign
    rm = rollout_dmp(mod, x0=x0, g=flipped_g, n_steps=2000)
    ro = rollout_dmp(org, x0=x0, g=flipped_g, n_steps=2000)
    demo_shape = _normalised_shape(x)[:, 1]

    def corr(r: object) -> float:
        return float(np.corrcoef(demo_shape, _normalised_shape(r.x)[:, 1])[0, 1])  # type: ignore[attr-defined]

    assert corr(rm) > 0.95  # modified: the bump over the cup is kept
    assert corr(ro) < -0.9  # original: (g - x0) f flips sign, the bump is mirrored
    # start near the goal: the modified DMP keeps the bump, the original collapses it
    near = x0 + np.array([0.6, 1e-4])
    rm = rollout_dmp(mod, x0=x0, g=near, n_steps=2000)
    ro = rollout_dmp(org, x0=x0, g=near, n_steps=2000)
    amp_demo = np.ptp(demo_shape)
    assert corr(rm) > 0.95
    assert np.ptp(_normalised_shape(rm.x)[:, 1]) > 0.8 * amp_demo
    assert np.ptp(_normalised_shape(ro.x)[:, 1]) < 0.05 * amp_demo


def test_temporal_scaling() -> None:
    t, pos = _demo()
    dmp = fit_dmp(t, pos)
    a = rollout_dmp(dmp, n_steps=1001)
    b = rollout_dmp(dmp, duration=2 * T, n_steps=1001)
    np.testing.assert_allclose(b.x, a.x, atol=1e-12)  # same path in phase
    np.testing.assert_allclose(b.xd, a.xd / 2, atol=1e-12)
    np.testing.assert_allclose(b.xdd, a.xdd / 4, atol=1e-12)


def test_coupling_is_linear() -> None:
    t, pos = _demo(300)
    dmp = fit_dmp(t, pos)
    n = 1001
    u = np.zeros((n, 3))
    u[400:600, 2] = np.hanning(200) * 0.5
    full = rollout_dmp(dmp, n_steps=n, coupling=u)
    base = rollout_dmp(dmp, n_steps=n)
    rx, _, _ = coupling_response(dmp.config, n, u)
    np.testing.assert_allclose(full.x, base.x + rx, atol=1e-12)


def test_bad_inputs() -> None:
    t, pos = _demo(100)
    with pytest.raises(InvalidInput, match="n_basis"):
        DmpConfig(n_basis=1)
    with pytest.raises(InvalidInput, match="variant"):
        DmpConfig(variant="fancy")
    with pytest.raises(InvalidInput, match="duration"):
        rollout_dmp(fit_dmp(t, pos), duration=0.0)
    with pytest.raises(InvalidInput, match="g - x0 = 0"):
        fit_dmp(t, np.ones((100, 1)), DmpConfig(variant="original"))
    with pytest.raises(InvalidInput, match="x0"):
        rollout_dmp(fit_dmp(t, pos), x0=np.array([0.1, np.nan, 0.2]))


def test_numba_kernels_match_numpy_reference() -> None:
    from dexlfd.plan.dmp import _grad

    rng = np.random.default_rng(42)
    t = np.sort(rng.uniform(0, 3, 200))  # non-uniform samples
    x = rng.normal(size=(200, 4))
    np.testing.assert_allclose(
        _grad(x, t), np.gradient(x, t, axis=0, edge_order=2), rtol=1e-10, atol=1e-9
    )
    for cfg in (DmpConfig(n_basis=30), DmpConfig(n_basis=12, alpha_s=20.0)):
        _check_kernels(cfg)


def _check_kernels(cfg: DmpConfig) -> None:
    from dexlfd.plan.forcing import _psi, basis_functions

    tt, pos = _demo(300)
    dmp = fit_dmp(tt, pos, cfg)
    s = phase(np.linspace(0, 1, 300), cfg.alpha_s)
    c, h = basis_functions(cfg)
    psi = _psi(s, c, h)
    ref = (psi @ dmp.weights.T) / psi.sum(axis=1, keepdims=True) * s[:, None]
    np.testing.assert_allclose(forcing(dmp, s), ref, rtol=1e-12, atol=1e-14)
    # LWR (Eq. 5.4) with dense NumPy algebra
    tb = tt / tt[-1]
    f_t, _ = _forcing_target(tb, pos, pos[-1], pos[0], cfg)
    s = phase(tb, cfg.alpha_s)
    psi = _psi(s, c, h)
    dt = np.gradient(tb)
    w_ref = ((psi * (s * dt)[:, None]).T @ f_t / (psi * (s * s * dt)[:, None]).sum(0)[:, None]).T
    np.testing.assert_allclose(dmp.weights, w_ref, rtol=1e-9, atol=1e-12)
