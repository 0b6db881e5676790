"""Planning: nonsense that used to be planned without a word."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.errors import InvalidInput
from dexlfd.io import LearnedModel, save_model
from dexlfd.plan import Box, PlanConfig, check_model_covariance, plan_from_model


def test_obstacle_push_under_the_table_is_refused(flat_model: LearnedModel) -> None:
    # a 0.6 m column standing on the table under the carry, passed "below" (@-z)
    column = Box((0.45, 0.0, 0.3), (0.1, 0.1, 0.6), "-z")
    with pytest.raises(InvalidInput, match=r"obstacle 0 pushes the plan \d+ mm below the table"):
        plan_from_model(flat_model, PlanConfig(obstacles=(column,), rate_hz=100))
    # over the top it is fine
    over = dataclasses.replace(column, direction="+z")
    plan = plan_from_model(flat_model, PlanConfig(obstacles=(over,), rate_hz=100))
    assert plan.position[:, 2].min() > 0.0


@pytest.mark.parametrize(
    ("goal", "match"),
    [
        ((0.0, 0.0, 0.333), "inside the arm itself"),  # the shoulder
        ((0.1, 0.05, 0.40), "inside the arm itself"),  # 0.13 m from it
        ((0.0, 0.0, 1.3), "beyond its reach"),
        ((1.0, 0.0, 0.3), "beyond its reach"),
    ],
)
def test_goal_at_the_shoulder_or_out_of_reach_is_refused(
    ref_model: LearnedModel, goal, match
) -> None:
    with pytest.raises(InvalidInput, match=match):
        plan_from_model(ref_model, PlanConfig(goal=goal, rate_hz=100))


def _with_cov(model: LearnedModel, cov: np.ndarray) -> LearnedModel:
    return dataclasses.replace(model, cov=cov)


def test_covariance_must_be_symmetric_positive_semidefinite(ref_model: LearnedModel) -> None:
    check_model_covariance(ref_model)  # a real one passes
    neg = ref_model.cov.copy()
    neg[50:60] *= -1.0  # negative definite
    with pytest.raises(InvalidInput, match=r"cov\[50\].*negative eigenvalue"):
        plan_from_model(_with_cov(ref_model, neg), PlanConfig(rate_hz=100))
    asym = ref_model.cov.copy()
    asym[7, 0, 1] += 1e-3
    with pytest.raises(InvalidInput, match=r"cov\[7\].*not symmetric"):
        plan_from_model(_with_cov(ref_model, asym), PlanConfig(rate_hz=100))


@pytest.mark.parametrize("kind", ["negative", "asymmetric"])
def test_plan_command_names_the_model_file(
    tmp_path: Path, ref_model: LearnedModel, capsys, kind: str
) -> None:
    cov = ref_model.cov.copy()
    if kind == "negative":
        cov *= -1.0
    else:
        cov[:, 0, 2] += 1e-2
    path = tmp_path / f"{kind}.npz"
    try:
        save_model(path, _with_cov(ref_model, cov))
    except InvalidInput:
        pytest.skip("save_model already refuses this covariance")
    out = tmp_path / "p.npz"
    rc = main(["plan", str(path), "-o", str(out)])
    err = capsys.readouterr().err
    assert rc == 1
    assert str(path) in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_plan_command_refuses_a_goal_at_the_shoulder(tmp_path: Path, ref_model, capsys) -> None:
    path = save_model(tmp_path / "m.npz", ref_model)
    rc = main(["plan", str(path), "--goal", "0,0,0.333", "-o", str(tmp_path / "p.npz")])
    err = capsys.readouterr().err
    assert rc == 1 and "inside the arm itself" in err and "Traceback" not in err


def test_plan_command_places_on_a_surface(tmp_path: Path, ref_model, capsys) -> None:
    from dexlfd.io import load_plan

    path = save_model(tmp_path / "m.npz", ref_model)
    out = tmp_path / "p.npz"
    rc = main(["plan", str(path), "--place-surface-m", "0.05", "--rate-hz", "100", "-o", str(out)])
    assert rc == 0
    place = load_plan(out).place_correction
    assert place.surface_z == 0.05 and place.support.size[2] == 0.05
    rc = main(["plan", str(path), "--place-surface-m", "-1", "-o", str(tmp_path / "q.npz")])
    err = capsys.readouterr().err
    assert rc == 1 and "--place-surface-m" in err and "Traceback" not in err
