from __future__ import annotations

import importlib
import tracemalloc

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.learn import accumulated_cost, channel_scales, dtw, sakoe_chiba_bounds

A = [0.1, 0.2, 0.5, 0.5, 0.3, 0.1, 0.1, 0.1, 0.2, 0.3]
B = [0.1, 0.1, 0.2, 0.3, 0.4, 0.5, 0.3, 0.2, 0.1, 0.2]


def naive_dtw(x: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray]:
    """Textbook O(nm) DTW with a full matrix and the same tie-break (diag, up, left)."""
    x = np.atleast_2d(np.asarray(x, float).T).T
    y = np.atleast_2d(np.asarray(y, float).T).T
    n, m = len(x), len(y)
    C = np.full((n, m), np.inf)
    for i in range(n):
        for j in range(m):
            e = float(np.sqrt(((x[i] - y[j]) ** 2).sum()))
            if i == 0 and j == 0:
                C[i, j] = e
                continue
            cands = [
                C[i - 1, j - 1] if i and j else np.inf,
                C[i - 1, j] if i else np.inf,
                C[i, j - 1] if j else np.inf,
            ]
            C[i, j] = e + min(cands)
    i, j = n - 1, m - 1
    path = [(i, j)]
    while (i, j) != (0, 0):
        cands = [
            C[i - 1, j - 1] if i and j else np.inf,
            C[i - 1, j] if i else np.inf,
            C[i, j - 1] if j else np.inf,
        ]
        k = int(np.argmin(cands))  # first minimum: diagonal, then up, then left
        i, j = [(i - 1, j - 1), (i - 1, j), (i, j - 1)][k]
        path.append((i, j))
    return float(C[-1, -1]), np.array(path[::-1])


def test_thesis_worked_example() -> None:
    # Thesis §4.3.2: grid rows are b_i, columns a_j; the text states the optimal path passes
    # (b4, a2). Cost by hand along the path below: the |b_i - a_j| of the 12 matched pairs
    # 0+0+0+0.1+0.1+0+0+0.1+0+0.1+0+0.1 = 0.4 (the thesis prints the matrices only as
    # figures, no number for the total).
    res = dtw(B, A)
    np.testing.assert_allclose(res.cost, 0.4, atol=1e-12)
    expected = [(0, 0), (1, 0), (2, 1), (3, 1), (4, 2), (5, 3), (6, 4), (7, 5), (8, 6)]
    expected += [(8, 7), (9, 8), (9, 9)]
    assert res.path.tolist() == [list(p) for p in expected]
    assert [3, 1] in res.path.tolist()  # (b4, a2), 0-based
    pairs_cost = np.abs(np.array(B)[res.path[:, 0]] - np.array(A)[res.path[:, 1]]).sum()
    np.testing.assert_allclose(pairs_cost, res.cost, atol=1e-12)
    C = accumulated_cost(B, A)
    np.testing.assert_allclose(C[-1, -1], 0.4, atol=1e-12)
    # ties: a cell lies on some optimal path iff forward + backward cost - E(cell) = 0.4.
    # Six optimal paths exist (all cost 0.4); every one passes (b4, a2), as the thesis says.
    E = np.abs(np.array(B)[:, None] - np.array(A)[None, :])
    back = accumulated_cost(B[::-1], A[::-1])[::-1, ::-1]
    on_optimal = np.isclose(C + back - E, 0.4, atol=1e-9)
    row_3 = np.flatnonzero(on_optimal[3])
    assert row_3.tolist() == [1]  # in row b4 only a2 is on an optimal path
    assert on_optimal[tuple(res.path.T)].all()


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (7, 1), (13, 29), (40, 33)])
def test_matches_naive_implementation(rng: np.random.Generator, shape: tuple[int, int]) -> None:
    n, m = shape
    x = rng.normal(size=(n, 3))
    y = rng.normal(size=(m, 3))
    res = dtw(x, y)
    cost, path = naive_dtw(x, y)
    np.testing.assert_allclose(res.cost, cost, rtol=1e-12)
    np.testing.assert_array_equal(res.path, path)
    np.testing.assert_allclose(accumulated_cost(x, y)[-1, -1], cost, rtol=1e-12)


def test_path_is_monotone_continuous_and_sums_to_cost(rng: np.random.Generator) -> None:
    for _ in range(5):
        x = rng.normal(size=(rng.integers(2, 120), 8))
        y = rng.normal(size=(rng.integers(2, 120), 8))
        res = dtw(x, y)
        p = res.path
        assert p[0].tolist() == [0, 0]
        assert p[-1].tolist() == [len(x) - 1, len(y) - 1]
        steps = np.diff(p, axis=0)
        assert ((steps == 0) | (steps == 1)).all() and (steps.sum(axis=1) >= 1).all()
        e = np.linalg.norm(x[p[:, 0]] - y[p[:, 1]], axis=1).sum()
        np.testing.assert_allclose(e, res.cost, rtol=1e-12)


def test_self_distance_is_zero_with_diagonal_path(rng: np.random.Generator) -> None:
    x = rng.normal(size=(200, 8))
    res = dtw(x, x)
    assert res.cost == 0.0
    np.testing.assert_array_equal(res.path, np.stack([np.arange(200)] * 2, axis=1))


def test_symmetric_cost(rng: np.random.Generator) -> None:
    x, y = rng.normal(size=(50, 2)), rng.normal(size=(61, 2))
    np.testing.assert_allclose(dtw(x, y).cost, dtw(y, x).cost, rtol=1e-12)


def test_time_warped_copy_is_found(rng: np.random.Generator) -> None:
    u = np.linspace(0, 1, 300)
    warped = u**1.6
    f = np.stack([np.sin(2 * np.pi * u), np.cos(3 * np.pi * u)], 1)
    g = np.stack([np.sin(2 * np.pi * warped), np.cos(3 * np.pi * warped)], 1)
    res = dtw(g, f)
    # matched phases agree to within the sampling step of the steepest part of the warp
    np.testing.assert_allclose(warped[res.path[:, 0]], u[res.path[:, 1]], atol=0.02)
    assert res.normalized_cost < 0.02 * dtw(g[::-1], f).normalized_cost + 0.05


def test_scale_divides_channels(rng: np.random.Generator) -> None:
    x, y = rng.normal(size=(30, 3)), rng.normal(size=(25, 3))
    s = np.array([2.0, 0.5, 10.0])
    a = dtw(x, y, scale=s)
    b = dtw(x / s, y / s)
    np.testing.assert_allclose(a.cost, b.cost, rtol=1e-12)
    np.testing.assert_array_equal(a.path, b.path)


def test_channel_scales_groups() -> None:
    x = np.stack([np.linspace(0, 2, 50), np.linspace(0, 2, 50), np.zeros(50), np.ones(50)], 1)
    x[:, 2] = np.sin(np.linspace(0, 6, 50)) * 1e-3
    s = channel_scales([x], groups=[[0, 1], [2]])
    np.testing.assert_allclose(s[0], s[1], rtol=1e-12)
    np.testing.assert_allclose(s[0], x[:, 0].std(), rtol=1e-12)
    np.testing.assert_allclose(s[2], x[:, 2].std(), rtol=1e-12)
    assert s[3] == 1.0  # constant channel: no blow-up
    with pytest.raises(InvalidInput, match="groups"):
        channel_scales([x], groups=[[0, 7]])


def test_band(rng: np.random.Generator) -> None:
    x, y = rng.normal(size=(80, 2)), rng.normal(size=(90, 2))
    full = dtw(x, y)
    banded = dtw(x, y, band=3)
    assert banded.cost >= full.cost - 1e-12
    lo, hi = sakoe_chiba_bounds(80, 90, 3)
    i, j = banded.path[:, 0], banded.path[:, 1]
    assert ((j >= lo[i]) & (j <= hi[i])).all()
    np.testing.assert_allclose(dtw(x, y, band=200).cost, full.cost, rtol=1e-12)
    # one series 10x longer: a band too narrow to connect the corners is widened
    long = rng.normal(size=(400, 2))
    res = dtw(x[:40], long, band=1)
    assert res.path[-1].tolist() == [39, 399] and np.isfinite(res.cost)


@pytest.mark.parametrize(("n", "m", "band"), [(25, 31, 4), (12, 90, 2), (90, 12, 0), (40, 40, 1)])
def test_banded_matches_naive_with_band(
    rng: np.random.Generator, n: int, m: int, band: int
) -> None:
    x, y = rng.normal(size=(n, 2)), rng.normal(size=(m, 2))
    lo, hi = sakoe_chiba_bounds(n, m, band)
    assert lo[0] == 0 and hi[-1] == m - 1 and (np.diff(lo) >= 0).all() and (np.diff(hi) >= 0).all()
    # naive banded DTW: +inf outside the band
    C = np.full((n, m), np.inf)
    for i in range(n):
        for j in range(lo[i], hi[i] + 1):
            e = np.linalg.norm(x[i] - y[j])
            prev = [
                C[i - 1, j - 1] if i and j else np.inf,
                C[i - 1, j] if i else np.inf,
                C[i, j - 1] if j else np.inf,
            ]
            C[i, j] = e if i == 0 and j == 0 else e + min(prev)
    res = dtw(x, y, band=band)
    np.testing.assert_allclose(res.cost, C[-1, -1], rtol=1e-12)
    i, j = res.path[:, 0], res.path[:, 1]
    assert ((j >= lo[i]) & (j <= hi[i])).all()


def test_memory_bounded_at_4000() -> None:
    rng = np.random.default_rng(0)
    x, y = rng.normal(size=(4000, 8)), rng.normal(size=(4000, 8))
    dtw(x[:10], y[:10])  # compile/load outside the measurement
    tracemalloc.start()
    try:
        res = dtw(x, y)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak <= 10e6, f"peak {peak / 1e6:.1f} MB"
    assert res.path.shape[1] == 2 and res.path[-1].tolist() == [3999, 3999]


@pytest.mark.parametrize(
    ("x", "y", "match"),
    [
        (np.zeros((5, 2)), np.zeros((5, 3)), "same number of channels"),
        (np.zeros((0, 2)), np.zeros((5, 2)), "n >= 1"),
        (np.array([[0.0, np.nan]]), np.zeros((5, 2)), "finite"),
        (np.array([[0.0, np.inf]]), np.zeros((5, 2)), "finite"),
        (np.zeros((2, 2, 2)), np.zeros((5, 2)), "shape"),
    ],
)
def test_bad_input(x: np.ndarray, y: np.ndarray, match: str) -> None:
    with pytest.raises(InvalidInput, match=match):
        dtw(x, y)


def test_bad_band_and_scale() -> None:
    with pytest.raises(InvalidInput, match="band"):
        dtw(np.zeros(3), np.zeros(3), band=-1)
    with pytest.raises(InvalidInput, match="scale"):
        dtw(np.zeros((3, 2)), np.zeros((3, 2)), scale=np.array([1.0, 0.0]))


@pytest.mark.slow
def test_numba_kernel_is_cached_across_processes(tmp_path) -> None:
    import os
    import subprocess
    import sys
    from pathlib import Path

    code = (
        "import numpy as np\n"
        "from dexlfd.learn import dtw\n"
        "print(dtw(np.zeros((5, 3)), np.ones((7, 3))).cost)\n"
    )
    src = str(Path(__file__).resolve().parents[2] / "src")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": src}
    env.pop("NUMBA_DISABLE_JIT", None)

    def first_call() -> float:
        run = subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
        )
        return float(run.stdout.split()[-1])

    first_call()  # compiles and writes the cache
    assert list(tmp_path.rglob("*.nbi")), "no numba cache index written"
    written = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*") if p.is_file()}
    warm = first_call()
    # a cache hit writes nothing new (deterministic, unlike comparing two timings;
    # the compile time itself is in benchmarks/bench_learn.py)
    assert {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*") if p.is_file()} == written
    assert warm == pytest.approx(7.0 * np.sqrt(3.0))  # and the cached kernel is right: 7 matches


def test_chunked_recursion_matches_one_chunk(rng: np.random.Generator, monkeypatch) -> None:
    """Rows computed a few at a time (Python between the calls) give the same path and cost."""
    dtw_module = importlib.import_module("dexlfd.learn.dtw")  # the name dtw is the function

    x, y = rng.standard_normal((157, 3)), rng.standard_normal((131, 3))
    whole = dtw(x, y, band=40)
    for cells in (1, 50, 333):  # 1: one row per call; odd counts swap the row buffers
        monkeypatch.setattr(dtw_module, "_CHUNK_CELLS", cells)
        part = dtw(x, y, band=40)
        np.testing.assert_array_equal(part.path, whole.path)
        assert part.cost == whole.cost
    expected = accumulated_cost(x, y)[-1, -1]
    np.testing.assert_allclose(dtw(x, y).cost, expected, rtol=1e-12, atol=0)


def test_ctrl_c_between_chunks_stops_the_recursion(rng: np.random.Generator, monkeypatch) -> None:
    """Python runs between chunks of rows, so a pending Ctrl-C is raised there."""
    dtw_module = importlib.import_module("dexlfd.learn.dtw")  # the name dtw is the function

    rows = dtw_module._dtw_rows
    calls = []

    def interrupted_after_two(*args):
        calls.append(args[-2:])
        if len(calls) == 3:
            raise KeyboardInterrupt  # what Python's SIGINT handler raises between bytecodes
        return rows(*args)

    monkeypatch.setattr(dtw_module, "_CHUNK_CELLS", 64)
    monkeypatch.setattr(dtw_module, "_dtw_rows", interrupted_after_two)
    with pytest.raises(KeyboardInterrupt):
        dtw(rng.standard_normal((64, 2)), rng.standard_normal((64, 2)))
    assert calls == [(0, 1), (1, 2), (2, 3)]  # 64 cells a row: one row per call


def test_grid_size_bound_at_its_ends() -> None:
    from dexlfd.learn.dtw import MAX_CELLS, check_dtw_size

    assert check_dtw_size(MAX_CELLS // 1000, 1000, None) == MAX_CELLS
    with pytest.raises(InvalidInput, match=r"at most 1e\+09.*band_fraction"):
        check_dtw_size(MAX_CELLS // 1000 + 1, 1000, None)
    # a band counts only its cells: a grid far over the bound fits with a narrow band
    assert check_dtw_size(100_000, 100_000, 500) <= MAX_CELLS < 100_000**2


def test_dtw_over_the_bound_is_refused_before_allocating(monkeypatch) -> None:
    dtw_module = importlib.import_module("dexlfd.learn.dtw")  # the name dtw is the function

    monkeypatch.setattr(dtw_module, "MAX_CELLS", 99)
    x = np.zeros((10, 2))
    assert dtw(x, x, band=1).cost == 0.0  # 28 of the grid's 100 cells
    with pytest.raises(InvalidInput, match="DTW of 10 x 10 samples spans 100 cells"):
        dtw(x, x)
