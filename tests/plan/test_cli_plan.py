from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd._commands._obstacle_args import parse_obstacle
from dexlfd.cli import main
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, Sphere
from dexlfd.io import load_plan, save_demonstration, save_model


@pytest.fixture
def model_file(tmp_path: Path, ref_model) -> Path:
    return save_model(tmp_path / "model.npz", ref_model)


def test_plan_command_with_obstacles_and_plots(model_file: Path, tmp_path: Path, fake_progress):
    import dexlfd._commands._common as common

    bars = fake_progress(common)
    out = tmp_path / "plan.npz"
    figs = tmp_path / "figs"
    rc = main(
        [
            "plan",
            str(model_file),
            "--start",
            "0.37,-0.34,0.22",
            "--goal",
            "0.51,0.11,0.31",
            "--obstacle",
            "box:0.47,-0.05,0.1,0.1,0.1,0.2",
            "--obstacle",
            "sphere:0.5,0.2,0.05,0.05",
            "--duration-s",
            "10",
            "--rate-hz",
            "100",
            "-o",
            str(out),
            "--plot",
            str(figs),
            "-q",
        ]
    )
    assert rc == 0
    plan = load_plan(out)
    np.testing.assert_allclose(plan.position[-1], [0.51, 0.11, 0.31], atol=1e-3)
    assert plan.t[-1] == pytest.approx(10.0)
    assert len(plan.obstacle_passes) == 2
    assert (figs / "plan_paths.png").stat().st_size > 10_000
    assert (figs / "plan_obstacles.png").stat().st_size > 10_000
    # one bar over the phases, each shown as it starts, every one counted when done
    (bar,) = bars
    phases = ["plan the motion", "time scaling", "arm posture", "write", "figures"]
    assert (bar.desc, bar.total, bar.n) == ("plan", 5, 5)
    assert bar.shown == [(name, i) for i, name in enumerate(phases)]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--goal", "1.5,0,0.3"], "goal"),
        (["--start", "0.4,0.1"], "--start"),
        (["--goal-quat", "0,0,0,3"], "--goal-quat must be a unit quaternion"),
        (["--obstacle", "box:0.4,-0.3,0.27,0.1,0.1,0.1"], "start"),
        (["--obstacle", "pyramid:1,2,3"], "--obstacle"),
        (
            ["--obstacle", "box:0.47,-0.05,0.1,0.1,0.1,0.2", "--margin-m", "1", "--rate-hz", "100"],
            "--margin-m: no coupling lifts the path enough to pass the obstacle with the margin",
        ),
        (["--whole-motion", "--object-size-m", "0.05,0.05,0.06"], "--object-size-m sizes the"),
    ],
)
def test_plan_command_bad_input(model_file: Path, tmp_path: Path, capsys, args, message) -> None:
    rc = main(["plan", str(model_file), *args, "-o", str(tmp_path / "p.npz")])
    err = capsys.readouterr().err
    assert rc == 1
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize("value", ["0", "-3", "nan", "541"])
def test_plan_duration_out_of_range_is_usage_error(model_file: Path, tmp_path: Path, capsys, value):
    with pytest.raises(SystemExit) as exc:
        main(["plan", str(model_file), "--duration-s", value, "-o", str(tmp_path / "p.npz")])
    assert exc.value.code == 2
    assert "--duration-s: expected a number in (0, 540]" in capsys.readouterr().err


def test_plan_command_wrong_file_kind(tmp_path: Path, demos, capsys) -> None:
    demo = save_demonstration(tmp_path / "demo.npz", demos[0])
    assert main(["plan", str(demo), "-o", str(tmp_path / "p.npz")]) == 1
    assert "expected a 'model' file" in capsys.readouterr().err
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    assert main(["plan", str(junk), "-o", str(tmp_path / "p.npz")]) == 1
    assert "not a readable .npz" in capsys.readouterr().err


def test_plan_command_wrong_model_version(model_file: Path, tmp_path: Path, capsys) -> None:
    with np.load(model_file, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["format_version"] = np.asarray(99)
    future = tmp_path / "future.npz"
    np.savez(future, **arrays)
    assert main(["plan", str(future), "-o", str(tmp_path / "p.npz")]) == 1
    assert "format_version 99 is not supported" in capsys.readouterr().err


def test_parse_obstacle() -> None:
    b = parse_obstacle("box:0.45,0,0.2,0.1,0.1,0.4")
    assert b == Box((0.45, 0.0, 0.2), (0.1, 0.1, 0.4), "+z")
    s = parse_obstacle("sphere:0.5,0.1,0.3,0.05@+y")
    assert s == Sphere((0.5, 0.1, 0.3), 0.05, "+y")
    # messages name an obstacle as the flag spells it, and that spelling parses back
    for spec in (
        "box:0.45,0,0.2,0.1,0.1,0.4",
        "sphere:0.5,0.1,0.3,0.05@+y",
        "box:-0.3,0.25,0.1,0.08,0.08,0.3@auto",
    ):
        assert parse_obstacle(spec).spec() == spec
        assert parse_obstacle(parse_obstacle(spec).spec()) == parse_obstacle(spec)
    for bad, match in [
        ("box:1,2,3", "6 numbers"),
        ("sphere:1,2,3", "4 numbers"),
        ("cone:1,2,3,4", "unknown kind"),
        ("box:a,b,c,d,e,f", "numbers"),
        ("box:0,0,0,0.1,-0.1,0.1", "size"),
        ("sphere:0,0,0,0", "radius"),
        ("box:0,0,0,1,1,1@up", "direction"),
        ("0,0,0,1", "expected box"),
        ("box:450,0,200,100,100,100", r"in metres.*box:0\.45,0,0\.2,0\.1,0\.1,0\.1 if you meant"),
        ("sphere:0.5,0,0.3,1e308", "within 5 m"),
        ("sphere:0.5,0,0.3,nan", "finite"),
    ]:
        with pytest.raises(InvalidInput, match=match):
            parse_obstacle(bad)


def test_out_of_reach_model_blames_the_users_goal_first(tmp_path: Path, ref_model, capsys) -> None:
    """Review item 6: a model out of reach (z + 1 m); the user gave only a goal."""
    mean = ref_model.mean.copy()
    mean[:, 2] += 1.0
    far = type(ref_model)(
        t=ref_model.t, mean=mean, cov=ref_model.cov, gmm_weights=ref_model.gmm_weights,
        gmm_means=ref_model.gmm_means, gmm_covs=ref_model.gmm_covs, meta=ref_model.meta,
    )  # fmt: skip
    model = save_model(tmp_path / "far.npz", far)
    out = str(tmp_path / "p.npz")
    assert main(["plan", str(model), "--goal", "5,0,0", "-o", out, "-q"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert err.startswith("dexlfd plan: error: --goal [5.0, 0.0, 0.0] m is outside")
    # a reachable goal: now the default start is to blame, said as such
    assert main(["plan", str(model), "--goal", "0.5,0,0.3", "-o", out, "-q"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "--start: the default start (the model's first position)" in err
    assert err.endswith("give a start within reach")
    assert not Path(out).exists()


def test_a_plan_out_of_reach_is_refused_with_the_reason(model_file: Path, tmp_path: Path, capsys):
    # a 1 m box across the path: the path over it leaves the Panda's reach; no timing
    # can fix that, so the command exits 1 and writes nothing. (A 0.4 m box beside the
    # path, which it never had to be lifted over, used to be passed with a 1.8 m push.)
    out = tmp_path / "plan.npz"
    rc = main(["plan", str(model_file), "--start", "0.37,-0.34,0.22", "--goal", "0.51,0.11,0.31",
               "--obstacle", "box:0.55,-0.1,0.5,0.1,0.1,1.0", "--rate-hz", "100",
               "-o", str(out)])  # fmt: skip
    assert rc == 1 and not out.exists()
    assert "outside the Panda's workspace" in capsys.readouterr().err
