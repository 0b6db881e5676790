from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import numpy as np
import pytest

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.errors import InvalidDemonstration, InvalidInput
from dexlfd.io import Demonstration, load_model, save_model
from dexlfd.learn import (
    LearnConfig,
    learn_from_demonstrations,
    learn_poses,
    learn_trajectories,
)
from dexlfd.learn.model_selection import K_CANDIDATES

LOGGER = "dexlfd.learn"


def _with_invalid(demo: Demonstration, bad: np.ndarray) -> Demonstration:
    valid = demo.valid.copy()
    valid[bad] = False
    pos, quat, grip = demo.position.copy(), demo.quaternion.copy(), demo.gripper.copy()
    pos[bad] = np.nan
    quat[bad] = np.nan
    grip[bad] = np.nan
    return dataclasses.replace(demo, valid=valid, position=pos, quaternion=quat, gripper=grip)


def test_learns_the_synthetic_task(demos: list[Demonstration]) -> None:
    res = learn_from_demonstrations(demos, LearnConfig(n_components=6), np.random.default_rng(0))
    model = res.model
    traj = res.trajectory
    m = traj.t_reference.size
    assert model.mean.shape == (m, 8) and model.cov.shape == (m, 8, 8)
    assert model.gmm_means.shape == (6, 9) and model.gmm_covs.shape == (6, 9, 9)
    np.testing.assert_allclose(np.linalg.norm(model.mean[:, 3:7], axis=1), 1.0, rtol=1e-12)
    # covariance symmetric PSD; the quaternion block has no variance along q itself
    np.testing.assert_allclose(model.cov, np.swapaxes(model.cov, 1, 2), atol=1e-15)
    assert np.linalg.eigvalsh(model.cov).min() > -1e-12
    qq = np.einsum("ni,nij,nj->n", model.mean[:, 3:7], model.cov[:, 3:7, 3:7], model.mean[:, 3:7])
    np.testing.assert_allclose(qq, 0.0, atol=1e-12)
    # the mean follows the aligned demonstrations. K=6 (thesis) smooths the fast segments:
    # measured up to 4.4 cm outside the demonstrations' envelope at the fast retreat at the end
    A = model.extras["aligned"]
    assert A.shape == (6, m, 8)
    assert _outside(model.mean, A)[:, :3].max() < 0.05
    assert _outside(model.mean, A)[:, 7].max() < 0.015
    # the demonstrations' own pointwise spread is stored next to GMR's Sigma(t)
    C = model.extras["aligned_cov"]
    np.testing.assert_allclose(C[:, 2, 2], A[:, :, 2].var(axis=0, ddof=1), rtol=1e-10)
    # extras and meta
    assert int(model.extras["reference_index"]) == traj.alignment.reference_index
    assert model.extras["dtw_distance"].shape == (6,)
    assert model.extras["outlier"].dtype == bool
    assert model.meta["n_components"] == 6 and model.meta["variance_from_demonstrations"]
    assert model.meta["gmm_converged"]
    # the reference is the medoid of the pairwise distances
    D = traj.alignment.pairwise
    assert D is not None and traj.alignment.reference_index == int(np.argmin(D.sum(axis=1)))


def _outside(mean: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Distance of the mean outside the pointwise min/max envelope of the aligned demos."""
    return np.maximum(A.min(axis=0) - mean, 0) + np.maximum(mean - A.max(axis=0), 0)


def test_more_components_follow_the_demonstrations_closely(demos: list[Demonstration]) -> None:
    res = learn_from_demonstrations(demos, LearnConfig(n_components=12), np.random.default_rng(0))
    out = _outside(res.model.mean, res.model.extras["aligned"])
    assert out[:, :3].max() < 0.012 and out[:, 7].max() < 0.005


def test_default_chooses_k_and_follows_the_demonstrations(demos: list[Demonstration]) -> None:
    """The default K (held-out demonstration likelihood) fits the five-segment task like K=12."""
    res = learn_from_demonstrations(demos, LearnConfig(), np.random.default_rng(0))
    sel = res.trajectory.k_selection
    assert sel is not None and res.model.meta["n_components"] == sel.k > 6
    assert res.model.meta["settings"]["n_components"] == "auto"
    assert res.model.meta["n_components_selection"]["candidates"] == list(K_CANDIDATES)
    # 2 mm sensor noise: the thesis's mean filter (k = 10) is kept by the risk rule
    assert res.model.meta["settings"]["window"] == "auto" and res.model.meta["filter_window"] == 10
    out = _outside(res.model.mean, res.model.extras["aligned"])
    assert out[:, :3].max() < 0.012 and out[:, 7].max() < 0.005


def test_model_file_round_trip(demos: list[Demonstration], tmp_path: Path) -> None:
    cfg = LearnConfig(n_components=6, n_query=100)
    res = learn_from_demonstrations(demos, cfg, np.random.default_rng(0))
    path = save_model(tmp_path / "model.npz", res.model)
    back = load_model(path)
    assert back.mean.shape == (100, 8)
    np.testing.assert_array_equal(back.cov, res.model.cov)
    np.testing.assert_array_equal(back.extras["aligned"], res.model.extras["aligned"])
    assert back.meta["settings"]["n_components"] == 6


def test_deterministic(demos: list[Demonstration]) -> None:
    a = learn_from_demonstrations(demos, LearnConfig(gmm_init="kmeans++"), np.random.default_rng(5))
    b = learn_from_demonstrations(demos, LearnConfig(gmm_init="kmeans++"), np.random.default_rng(5))
    np.testing.assert_array_equal(a.model.mean, b.model.mean)
    np.testing.assert_array_equal(a.model.cov, b.model.cov)


def test_reference_by_index_as_in_thesis(demos: list[Demonstration]) -> None:
    res = learn_from_demonstrations(demos, LearnConfig(reference=4), np.random.default_rng(0))
    assert res.trajectory.alignment.reference_index == 4
    assert res.model.n_samples == demos[4].n_samples
    with pytest.raises(InvalidInput, match="reference index 9 out of range"):
        learn_from_demonstrations(demos, LearnConfig(reference=9), np.random.default_rng(0))


def test_single_demonstration_warns(demos: list[Demonstration], caplog) -> None:
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        res = learn_from_demonstrations(demos[:1], LearnConfig(), np.random.default_rng(0))
    assert "only one demonstration" in caplog.text
    assert res.model.meta["variance_from_demonstrations"] is False
    assert np.isfinite(res.model.cov).all()


def test_outlier_is_flagged_and_can_be_excluded(demos: list[Demonstration], caplog) -> None:
    bad = demos[3]
    shifted = dataclasses.replace(bad, position=bad.position + np.array([0.0, 0.0, 0.25]))
    data = [*demos[:3], shifted, *demos[4:]]
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        # K fixed: the comparison below is of the same model with and without the outlier
        res = learn_from_demonstrations(data, LearnConfig(n_components=6), np.random.default_rng(0))
    assert res.trajectory.quality.outlier.tolist() == [False, False, False, True, False, False]
    assert "consider excluding" in caplog.text
    assert res.trajectory.used.all()
    ex = learn_from_demonstrations(
        data, LearnConfig(n_components=6, exclude_outliers=True), np.random.default_rng(0)
    )
    assert ex.trajectory.used.tolist() == [True, True, True, False, True, True]
    assert ex.model.meta["excluded"] == ["demonstration 3"]
    # excluding the raised demonstration lowers the learned z and its variance
    assert ex.model.mean[:, 2].max() < res.model.mean[:, 2].max()
    assert ex.model.cov[:, 2, 2].mean() < res.model.cov[:, 2, 2].mean()


def test_invalid_frames_are_repaired_or_rejected(demos: list[Demonstration], caplog) -> None:
    n0 = demos[0].n_samples
    d0 = _with_invalid(demos[0], np.r_[0:3, 50:54, n0 - 6 : n0])
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        res = learn_from_demonstrations([d0, *demos[1:]], LearnConfig(), np.random.default_rng(0))
    assert "interpolated 4 invalid sample(s)" in caplog.text
    assert "dropped 3 invalid sample(s) at the start and 6 at the end" in caplog.text
    assert np.isfinite(res.model.mean).all()
    assert len(res.trajectory.series[0][0]) == demos[0].n_samples - 9
    long_gap = _with_invalid(demos[0], np.arange(60, 90))  # 1 s at 30 Hz
    with pytest.raises(InvalidDemonstration, match=r"demo_a.*exceed the max_gap_s=0.5"):
        learn_from_demonstrations(
            [long_gap, *demos[1:]],
            LearnConfig(),
            np.random.default_rng(0),
            names=["demo_a"] + [f"d{i}" for i in range(5)],
        )
    all_bad = _with_invalid(demos[0], np.arange(demos[0].n_samples))
    with pytest.raises(InvalidDemonstration, match="no valid sample"):
        learn_from_demonstrations([all_bad], LearnConfig(), np.random.default_rng(0))


def test_inf_is_rejected(demos: list[Demonstration]) -> None:
    poses = [d.pose for d in demos[:2]]
    poses[1] = poses[1].copy()
    poses[1][7, 0] = np.inf
    with pytest.raises(InvalidDemonstration, match="demonstration 1: pose contains inf"):
        learn_poses([d.t for d in demos[:2]], poses, LearnConfig(), np.random.default_rng(0))


def test_empty_and_one_sample_demos(demos: list[Demonstration]) -> None:
    with pytest.raises(InvalidInput, match="at least one"):
        learn_from_demonstrations([], LearnConfig(), np.random.default_rng(0))
    one = np.array([0.0])
    with pytest.raises(InvalidDemonstration, match="demonstration 1: needs at least 2 samples"):
        learn_poses(
            [demos[0].t, one],
            [demos[0].pose, demos[0].pose[:1]],
            LearnConfig(),
            np.random.default_rng(0),
        )
    with pytest.raises(InvalidDemonstration, match="needs at least 2 samples to learn from, got 0"):
        learn_trajectories(
            [np.zeros(0)], [np.zeros((0, 2))], LearnConfig(), np.random.default_rng(0)
        )


def test_mismatched_channels() -> None:
    t = np.linspace(0, 1, 50)
    with pytest.raises(InvalidDemonstration, match="b: has 3 channels, but a has 2"):
        learn_trajectories(
            [t, t],
            [np.zeros((50, 2)), np.zeros((50, 3))],
            LearnConfig(),
            np.random.default_rng(0),
            names=["a", "b"],
        )
    with pytest.raises(InvalidDemonstration, match=r"pose must have shape \(n, 8\)"):
        learn_poses([t], [np.zeros((50, 7))], LearnConfig(), np.random.default_rng(0))


def test_lengths_differing_tenfold(caplog) -> None:
    rng = np.random.default_rng(1)
    series, times = [], []
    for n in (40, 400, 380, 60):
        u = np.linspace(0, 1, n)
        times.append(u * n / 30)
        series.append(np.stack([np.sin(np.pi * u), u], 1) + rng.normal(0, 0.01, (n, 2)))
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        traj = learn_trajectories(times, series, LearnConfig(), rng)
    assert "lengths differ 10.0x" in caplog.text
    assert np.isfinite(traj.mean).all()
    ref_curve = np.stack(
        [np.sin(np.pi * np.linspace(0, 1, traj.t.size)), np.linspace(0, 1, traj.t.size)], 1
    )
    assert np.abs(traj.mean - ref_curve).max() < 0.1


def test_too_many_components_is_reduced(caplog) -> None:
    t = np.linspace(0, 1, 8)
    x = np.stack([t, t**2], 1)
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        traj = learn_trajectories(
            [t, t], [x, x + 0.01], LearnConfig(n_components=6, window=1), np.random.default_rng(0)
        )
    assert "using K=4" in caplog.text
    assert traj.gmm_result.gmm.n_components == 4


def test_quaternion_sign_flips_and_non_unit(demos: list[Demonstration], caplog) -> None:
    base = learn_from_demonstrations(demos, LearnConfig(), np.random.default_rng(0)).model
    poses = [d.pose.copy() for d in demos]
    poses[1][:, 3:7] *= -1.0  # whole demonstration in the other hemisphere
    poses[2][100:, 3:7] *= -1.0  # sign jump in the middle
    poses[3][:, 3:7] *= 1.01  # not unit
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        res = learn_poses([d.t for d in demos], poses, LearnConfig(), np.random.default_rng(0))
    assert "quaternions not unit" in caplog.text and "renormalised" in caplog.text
    np.testing.assert_allclose(res.model.mean, base.mean, atol=1e-9)
    np.testing.assert_allclose(res.model.cov, base.cov, atol=1e-12)
    poses[4][10, 3:7] = 0.01
    with pytest.raises(InvalidDemonstration, match="demonstration 4: quaternion at sample 10"):
        learn_poses([d.t for d in demos], poses, LearnConfig(), np.random.default_rng(0))


def test_non_demonstration_input() -> None:
    with pytest.raises(InvalidInput, match="expected a Demonstration"):
        learn_from_demonstrations([np.zeros((5, 8))], LearnConfig(), np.random.default_rng(0))  # type: ignore[list-item]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_components": 0}, "n_components"),
        ({"window": 0}, "window"),
        ({"reference": "best"}, "reference"),
        ({"reference": -1}, "reference"),
        ({"filter_mode": "x"}, "filter_mode"),
        ({"band_fraction": 2.0}, "band_fraction"),
        ({"n_query": 1}, "n_query"),
        ({"gmm_max_iter": 0}, "max_iter"),
    ],
)
def test_bad_config(kwargs: dict, match: str) -> None:
    with pytest.raises(InvalidInput, match=match):
        LearnConfig(**kwargs)


def test_pick_place_fixture_is_synthetic(rng: np.random.Generator) -> None:
    d = pick_place_demonstrations(2, rng)
    assert d[0].meta["source"] == "synthetic"
