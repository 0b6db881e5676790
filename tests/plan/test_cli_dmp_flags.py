"""``dexlfd plan --dmp original|modified`` and the DMP / coupling gain flags (Eqs. 5.1-5.7)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.errors import InvalidInput
from dexlfd.io import load_plan, save_model
from dexlfd.plan import PlanConfig
from dexlfd.plan.dmp_config import DmpConfig

START, GOAL = "0.37,-0.34,0.22", "0.51,0.11,0.31"  # thesis §5.3.1's first new start and goal


@pytest.fixture
def model_file(tmp_path: Path, ref_model) -> Path:
    return save_model(tmp_path / "model.npz", ref_model)


@pytest.fixture
def sloped_model_file(tmp_path: Path, ref_model) -> Path:
    """The reference model with its goal moved in x and z: g - x0 != 0 on every axis,
    which the original DMP (Eq. 5.1) needs."""
    u = (ref_model.t - ref_model.t[0]) / (ref_model.t[-1] - ref_model.t[0])
    mean = ref_model.mean.copy()
    mean[:, 0] += 0.10 * u
    mean[:, 2] += 0.08 * u
    return save_model(tmp_path / "sloped.npz", dataclasses.replace(ref_model, mean=mean))


def _plan(model_file: Path, out: Path, *extra: str) -> np.ndarray:
    args = ["plan", str(model_file), "--whole-motion", "--start", START, "--goal", GOAL,
            "--duration-s", "8", "--rate-hz", "50", "-o", str(out), "-q", *extra]  # fmt: skip
    assert main(args) == 0
    return load_plan(out).position


def test_original_and_modified_dmp_differ_and_reach_the_goal(sloped_model_file, tmp_path):
    mod = _plan(sloped_model_file, tmp_path / "mod.npz")
    org = _plan(sloped_model_file, tmp_path / "org.npz", "--dmp", "original")
    for pos in (mod, org):
        np.testing.assert_allclose(pos[-1], [0.51, 0.11, 0.31], atol=2e-3)
        np.testing.assert_allclose(pos[0], [0.37, -0.34, 0.22], atol=1e-6)
    # Eq. (5.1) scales the learned shape by (g - x0) per axis, Eq. (5.5) does not
    assert np.abs(org - mod).max() > 0.02


def test_original_dmp_refuses_an_axis_without_motion(model_file, tmp_path, capsys) -> None:
    # the reference model starts and ends at the same x and z: (g - x0) f of Eq. (5.1) is 0
    args = ["plan", str(model_file), "--whole-motion", "--dmp", "original", "-o",
            str(tmp_path / "o.npz")]  # fmt: skip
    assert main(args) == 1
    assert "original DMP (Eq. 5.1)" in capsys.readouterr().err
    assert not (tmp_path / "o.npz").exists()


def test_basis_count_and_gains_reach_the_dmp(model_file, tmp_path) -> None:
    base = _plan(model_file, tmp_path / "a.npz")
    few = _plan(model_file, tmp_path / "b.npz", "--dmp-basis", "3")
    assert np.abs(few - base).max() > 5e-3  # 3 Gaussians cannot hold the learned shape
    soft = _plan(model_file, tmp_path / "c.npz", "--dmp-k", "0.5", "--dmp-d", "2")
    assert np.abs(soft - base).max() > 1e-4
    np.testing.assert_allclose(soft[-1], base[-1], atol=5e-3)


def test_coupling_gains_scale_the_thesis_coupling(model_file, ref_model, tmp_path) -> None:
    # a box under the learned path's peak; the thesis coupling (Eq. 5.6) pushes along +z
    from dexlfd.geometry import Box
    from dexlfd.plan import plan_from_model

    box = Box(center=(0.55, -0.1, 0.2), size=(0.1, 0.1, 0.44), direction="+z")
    start, goal = (np.array([float(v) for v in p.split(",")]) for p in (START, GOAL))

    def hand(k1: float = 10.0, c: float = 1.0, obstacles: tuple = (box,)) -> np.ndarray:
        # the hand's plan alone: the arm posture step (``dexlfd plan`` with obstacles)
        # may re-plan round a widened box, which is not the DMP's response
        cfg = PlanConfig(task="motion", start=start, goal=goal, duration=8.0, rate_hz=50.0,
                         obstacles=obstacles, variance_aware=False, enforce_clearance=False,
                         k1=k1, c=c)  # fmt: skip
        return plan_from_model(ref_model, cfg).position

    free = hand(obstacles=())
    lift = {(k1, c): (hand(k1, c) - free)[:, 2].max() for k1, c in ((2, 1), (5, 1), (2, 2.5))}
    assert lift[2, 1] > 0.01
    # the DMP's response is linear in the push c F(t) = c k1 h(t) (Eq. 5.6)
    assert lift[5, 1] == pytest.approx(2.5 * lift[2, 1], rel=1e-6)
    assert lift[2, 2.5] == pytest.approx(2.5 * lift[2, 1], rel=1e-6)
    # and the command line's flags reach it: a larger k1 pushes the path higher
    flags = ("--coupling", "thesis", "--no-variance", "--obstacle",
             "box:0.55,-0.1,0.2,0.1,0.1,0.44", "--coupling-c", "1")  # fmt: skip
    cli = {k1: _plan(model_file, tmp_path / f"{k1}.npz", *flags, "--k1", k1) for k1 in "25"}
    assert cli["5"][:, 2].max() > cli["2"][:, 2].max() + 0.01


@pytest.mark.parametrize(
    ("flag", "value", "accepted"),
    [
        ("--dmp-k", "0", "(0, 100]"),
        ("--dmp-d", "101", "(0, 100]"),
        ("--dmp-basis", "1", "2..1000"),
        ("--k1", "-1", "(0, 1000]"),
        ("--k2", "nan", "(0, 1000]"),
        ("--coupling-c", "2000", "(0, 1000]"),
        ("--dmp", "ijspeert", "original"),
    ],
)
def test_out_of_range_flags_are_usage_errors(model_file, tmp_path, capsys, flag, value,
                                             accepted) -> None:  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        main(["plan", str(model_file), "-o", str(tmp_path / "x.npz"), flag, value])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert flag in err and accepted in err
    assert not (tmp_path / "x.npz").exists()


def test_library_refuses_the_same_ranges() -> None:
    with pytest.raises(InvalidInput, match=r"DmpConfig.K must be in \(0, 100\]"):
        DmpConfig(K=101.0)
    with pytest.raises(InvalidInput, match="n_basis"):
        DmpConfig(n_basis=1001)
    with pytest.raises(InvalidInput, match=r"k2 must be in \(0, 1000\]"):
        PlanConfig(k2=1e4)
