"""How long a plan may last: what ``plan`` accepts and writes, ``simulate`` accepts.

Tracking records every 1 ms tick, so the plan contract bounds a plan's duration
(``MAX_DURATION_S``); ``plan --duration-s`` is bounded below it by the time a
pick-and-place adds to its motion (``MAX_MOTION_S``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io import Plan, load_plan, save_model, save_plan
from dexlfd.io.plan import MAX_DURATION_S
from dexlfd.plan import PlanConfig
from dexlfd.plan.config import MAX_MOTION_S

from .conftest import reference_model


def _still_plan(duration: float) -> Plan:
    """A plan that holds one pose for ``duration`` [s], sampled every 0.5 s."""
    n = int(np.ceil(duration / 0.5)) + 1
    t = np.linspace(0.0, duration, n)
    z = np.zeros((n, 3))
    return Plan(
        t=t,
        position=np.tile([0.45, 0.0, 0.35], (n, 1)),
        velocity=z,
        acceleration=z,
        quaternion=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
        angular_velocity=z,
        gripper=np.full(n, 0.08),
    )


def test_plan_contract_accepts_the_bound_and_refuses_beyond(tmp_path: Path) -> None:
    path = save_plan(tmp_path / "p.npz", _still_plan(MAX_DURATION_S))
    assert load_plan(path).t[-1] == MAX_DURATION_S
    with pytest.raises(InvalidInput, match=f"at most {MAX_DURATION_S:g} s"):
        _still_plan(MAX_DURATION_S + 0.5)


def test_simulate_refuses_a_longer_plan_file_in_one_line(tmp_path: Path, capsys) -> None:
    plan = _still_plan(MAX_DURATION_S)
    longer = {name: getattr(plan, name) for name in plan.SPECS if getattr(plan, name) is not None}
    longer["t"] = plan.t * (MAX_DURATION_S + 0.5) / MAX_DURATION_S
    longer["meta"] = np.asarray('{"kind": "plan"}')
    longer["format_version"] = np.asarray(2)
    path = tmp_path / "long.npz"
    np.savez(path, **longer)
    with pytest.raises(InvalidFile, match=r"long\.npz: .*at most 600 s"):
        load_plan(path)
    out = tmp_path / "r.npz"
    assert main(["simulate", str(path), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("dexlfd simulate: error: ") and "long.npz" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.npz"]


@pytest.mark.parametrize("hold", ["0.3", "5"])
def test_plan_at_the_longest_duration_writes_a_plan_simulate_accepts(
    tmp_path: Path, hold: str
) -> None:
    model = save_model(tmp_path / "m.npz", reference_model())
    out = tmp_path / "p.npz"
    argv = ["plan", str(model), "--duration-s", f"{MAX_MOTION_S:g}", "--hold-s", hold]
    assert main([*argv, "--rate-hz", "10", "-o", str(out), "-q"]) == 0
    plan = load_plan(out)  # the gate simulate loads it through
    assert MAX_MOTION_S <= plan.t[-1] - plan.t[0] <= MAX_DURATION_S


def test_plan_duration_flag_ends(tmp_path: Path, capsys) -> None:
    model = save_model(tmp_path / "m.npz", reference_model())
    out = tmp_path / "p.npz"
    with pytest.raises(SystemExit) as exc:
        main(["plan", str(model), "--duration-s", f"{MAX_MOTION_S + 0.001:g}", "-o", str(out)])
    assert exc.value.code == 2
    assert f"--duration-s: expected a number in (0, {MAX_MOTION_S:g}]" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(InvalidInput, match=r"PlanConfig.duration must be in \(0, 540\] s"):
        PlanConfig(duration=MAX_MOTION_S + 0.001)
    assert PlanConfig(duration=MAX_MOTION_S).duration == MAX_MOTION_S


def test_a_model_longer_than_a_plan_needs_a_duration(tmp_path: Path, capsys) -> None:
    long_model = reference_model(duration=MAX_MOTION_S + 10.0, m=800)
    model = save_model(tmp_path / "m.npz", long_model)
    out = tmp_path / "p.npz"
    assert main(["plan", str(model), "--rate-hz", "10", "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "--duration-s" in err[0] and "(default: the model's)" in err[0]
    assert not out.exists()
    assert main(["plan", str(model), "--duration-s", "10", "--rate-hz", "10", "-o", str(out)]) == 0
