from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.errors import InvalidInput
from dexlfd.io import load_demonstration


def test_synth_writes_demonstrations(tmp_path: Path) -> None:
    assert main(["synth", "-n", "2", "--seed", "1", "-o", str(tmp_path)]) == 0
    files = sorted(tmp_path.glob("demo_*.npz"))
    assert len(files) == 2
    assert load_demonstration(files[0]).meta["source"] == "synthetic"


def test_unknown_subcommand_is_usage_error() -> None:
    with pytest.raises(SystemExit) as exc:
        main(["fly"])
    assert exc.value.code == 2


def test_unwritable_output_is_one_line_error(tmp_path: Path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["synth", "-o", str(blocker / "sub")]) == 1
    err = capsys.readouterr().err
    assert "-o/--output" in err and "Traceback" not in err


def test_export_csv_and_wrong_kind(tmp_path: Path, capsys) -> None:
    main(["synth", "-n", "1", "-o", str(tmp_path)])
    demo = tmp_path / "demo_00.npz"
    assert main(["export", str(demo), "-o", str(tmp_path / "d.csv")]) == 0
    assert (tmp_path / "d.csv").read_text().startswith("t [s],")
    assert main(["export", str(demo), "-o", str(tmp_path / "bag")]) == 0  # MCAP bag
    assert main(["export", str(demo), "-o", str(tmp_path / "bag")]) == 1
    assert "already exists" in capsys.readouterr().err
    (tmp_path / "junk.npz").write_text("junk")
    assert main(["export", str(tmp_path / "junk.npz"), "-o", str(tmp_path / "x.csv")]) == 1
    assert "not a dexlfd file" in capsys.readouterr().err


def test_negative_seed_and_sizes_are_usage_errors(tmp_path: Path, capsys) -> None:
    for argv in (["synth", "-o", str(tmp_path), "--seed", "-1"],
                 ["synth", "-o", str(tmp_path), "-n", "0"]):  # fmt: skip
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
    assert "expected an integer" in capsys.readouterr().err


def test_outputs_are_checked_before_the_work(tmp_path: Path, capsys) -> None:
    main(["synth", "-n", "2", "-o", str(tmp_path / "demos")])
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    demos = sorted(str(p) for p in (tmp_path / "demos").glob("*.npz"))
    model = tmp_path / "m.npz"
    assert main(["learn", *demos, "-o", str(model), "--plot", str(blocker / "figs")]) == 1
    assert "--plot" in capsys.readouterr().err
    assert not model.exists()  # nothing written before the failure
    assert main(["learn", *demos, "-o", str(model)]) == 0
    plan = tmp_path / "p.npz"
    assert main(["plan", str(model), "-o", str(blocker / "p.npz")]) == 1
    assert "is a file, not a folder" in capsys.readouterr().err
    argv = ["plan", str(model), "-o", str(plan), "--duration-s", "500", "--rate-hz", "8000"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "samples" in err and "--rate-hz 8000" in err and not plan.exists()


# --------------------------------------------------------------------------- flag language


@pytest.mark.parametrize("command", ["record", "simulate", "teleop", "demo"])
def test_rerun_recording_errors_name_the_rerun_flag(command: str) -> None:
    from dexlfd.cli import _build_parser, _subparser, error_text

    flags = _subparser(_build_parser(), command).get_default("_params")
    exc = InvalidInput("rerun recording /d/x.txt: expected a .rrd file name", param="rerun")
    assert error_text(exc, flags) == "--rerun recording /d/x.txt: expected a .rrd file name"


@pytest.mark.parametrize(
    ("message", "param", "expected"),
    [
        ("margin must be >= 0", "margin", "--margin-m must be >= 0"),
        ("PlanConfig.margin must be in [0, 1] m", "margin", "--margin-m must be in [0, 1] m"),
        # a longer word that starts with the name is not the name
        ("margins differ", "margin", "--margin-m: margins differ"),
        ("no coupling lifts the path", "margin", "--margin-m: no coupling lifts the path"),
        # no param, or a param no flag sets: the library's words as they are
        ("/data/margin/x.npz: unreadable", None, "/data/margin/x.npz: unreadable"),
        ("band must be > 0", "band", "band must be > 0"),
    ],
)  # fmt: skip
def test_an_error_names_the_flag_of_its_param_and_nothing_else(message, param, expected) -> None:
    from dexlfd.cli import _build_parser, _subparser, error_text

    flags = _subparser(_build_parser(), "plan").get_default("_params")
    assert error_text(InvalidInput(message, param=param), flags) == expected


def test_library_file_errors_reach_the_user_as_flags(tmp_path: Path, capsys, monkeypatch) -> None:
    from dexlfd._commands import record
    from dexlfd.errors import InvalidFile
    from dexlfd.viz.capture import OverlayWriter

    target = tmp_path / "no" / "o.mp4"
    with pytest.raises(InvalidFile) as info:
        OverlayWriter(target, 30.0)
    assert str(info.value).startswith(f"overlay video {target}: folder")  # the library's words
    assert "--" not in str(info.value)

    def run(args: object) -> int:
        raise info.value

    monkeypatch.setattr(record, "run", run)
    assert main(["record", "hand.mp4", "-o", str(tmp_path / "d.npz")]) == 1
    err = capsys.readouterr().err
    assert f"error: --overlay video {target}: folder {target.parent} does not exist" in err


def test_export_dataset_settings_errors_name_the_flags(tmp_path: Path, capsys) -> None:
    main(["synth", "-n", "2", "-o", str(tmp_path / "d")])
    demos = sorted(str(p) for p in (tmp_path / "d").glob("demo_*.npz"))
    out = str(tmp_path / "ds")
    assert main(["export", *demos, "--format", "lerobot", "--fps", "0.2", "-o", out]) == 1
    assert "error: --fps must round to an integer >= 1 Hz, got 0.2" in capsys.readouterr().err
    assert main(["export", *demos, "--format", "lerobot", "--task", " ", "-o", out]) == 1
    assert "error: --task must be a non-empty description" in capsys.readouterr().err
    assert not (tmp_path / "ds").exists()


def test_simulate_fails_loudly_when_the_object_is_not_carried(tmp_path: Path, capsys) -> None:
    """Review item 3: a grasping run that does not carry the object exits 1, one line."""
    import numpy as np

    from dexlfd.io import load_rollout, save_plan
    from dexlfd.plan.moves import lift_plan

    plan = lift_plan(1.0, z_low=0.3, z_high=0.35, y_start=-0.02, y_end=0.02, gripper=0.08)
    plan = dataclasses.replace(plan, grasp=np.zeros(plan.t.shape, bool))
    src = save_plan(tmp_path / "open.npz", plan)  # the hand never closes: nothing carried
    out = tmp_path / "r.npz"
    rc = main(["simulate", str(src), "--payload", "0.5", "-o", str(out), "-q", "--no-noise"])
    assert rc == 1
    err = [ln for ln in capsys.readouterr().err.splitlines() if "error:" in ln]
    assert len(err) == 1
    assert "0.5 kg object was not carried: the plan never closes the gripper" in err[0]
    assert f"the rollout is in {out}" in err[0]
    ro = load_rollout(out)  # written all the same
    assert not np.asarray(ro.extras["attached"]).any()
    assert ro.grasp_schedule.intervals_s == ()


@pytest.mark.parametrize(
    "argv",
    [
        ["plan", "m.npz", "-o", "p.npz", "--place-surf", "0.1"],  # abbreviation of a flag
        ["synth", "-o", "d", "--se", "1"],
    ],
)
def test_flag_abbreviations_are_refused(argv: list[str], capsys) -> None:
    """A typo never passes as the flag it abbreviates (argparse's allow_abbrev is off)."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert "unrecognized arguments" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["record", "teleop"])
def test_fov_deg_range_in_help_is_the_range_accepted(command: str, tmp_path: Path, capsys) -> None:
    """--help says [1, 179]: both ends parse, just beyond them is a usage error."""
    from dexlfd.cli import _build_parser

    parser = _build_parser()
    with pytest.raises(SystemExit):
        parser.parse_args([command, "--help"])
    assert "[1, 179]" in " ".join(capsys.readouterr().out.split())
    base = [command, "video.mp4", "-o", str(tmp_path / "x.npz")]
    for ok in ("1", "179"):
        assert parser.parse_args([*base, "--fov-deg", ok]).fov_deg == float(ok)
    for bad in ("0.99", "179.01"):
        with pytest.raises(SystemExit):
            parser.parse_args([*base, "--fov-deg", bad])


@pytest.mark.parametrize(
    "flag, lo, hi, lo_open",
    [
        ("--smoothing-s", 0.0, 2.0, False),
        ("--max-speed", 0.0, 1.7, True),
        ("--max-angular-speed", 0.0, 2.5, True),
        ("--max-gripper-speed", 0.0, 0.2, True),
    ],
)
def test_teleop_shaping_flags_are_bounded_at_their_stated_ends(
    flag: str, lo: float, hi: float, lo_open: bool, tmp_path: Path, capsys
) -> None:
    from dexlfd.cli import _build_parser

    parser = _build_parser()
    with pytest.raises(SystemExit):
        parser.parse_args(["teleop", "--help"])
    stated = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
    assert stated in " ".join(capsys.readouterr().out.split())
    base = ["teleop", "video.mp4", "-o", str(tmp_path / "r.npz"), flag]
    dest = flag.lstrip("-").replace("-", "_")
    assert getattr(parser.parse_args([*base, str(hi)]), dest) == hi
    for bad in ([str(lo)] if lo_open else []) + [str(hi * 1.001), "1e308", "nan"]:
        with pytest.raises(SystemExit):
            parser.parse_args([*base, bad])


@pytest.mark.parametrize(
    "argv",
    [
        ["synth", "-n", "1", "-o", "{long}"],
        ["synth", "-n", "1", "-o", "{long}/sub"],
        ["plan", "model.npz", "-o", "{long}.npz"],
    ],
)
def test_a_name_longer_than_the_file_system_allows_is_one_line(
    argv: list[str], tmp_path: Path, capsys
) -> None:
    """A 256-byte file name: one line naming the path, never an OSError traceback."""
    long = str(tmp_path / ("a" * 256))
    assert main([a.format(long=long) for a in argv]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "File name too long" in err[0] and "aaaa" in err[0], err


@pytest.mark.parametrize(
    "flags, why",
    [
        (["--controllers", ""], "--controllers: expected NAME[,NAME...]"),
        (["--controllers", "pd,pd"], "pd named twice"),
        (["--controllers", "pd,nope"], "--controllers: unknown controller 'nope'; one of"),
        (["--trials", "1000000000"], "--trials: expected an integer in 0..100000"),
        (["--mc-delay-ticks", "100000000,100000001"], "expected 0 <= LO <= HI <= 100"),
        (["--mc-noise-scale", "0,1e308"], "expected 0 <= LO <= HI <= 100"),
        (["--mc-payload-kg", "nan,1"], "expected 0 <= LO <= HI <= 3"),
    ],
)
def test_experiment_payload_flags_are_bounded_before_any_run(
    flags: list[str], why: str, tmp_path: Path, capsys
) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["experiment", "payload", "-o", str(tmp_path / "out"), *flags])
    assert exc.value.code == 2
    assert why in " ".join(capsys.readouterr().err.split())
    assert not (tmp_path / "out").exists()


def test_help_lists_every_command_without_loading_the_stages() -> None:
    """``dexlfd --help`` and ``python -m dexlfd`` build the summaries only (no SciPy, numba)."""
    import subprocess
    import sys

    from dexlfd.cli import COMMANDS

    heavy = ("scipy", "numba", "mujoco", "cv2", "mediapipe", "matplotlib", "dexlfd.control",
             "dexlfd.capture")  # fmt: skip
    out = _help_in_fresh_interpreter(["--help"], heavy)
    assert out.strip().endswith("HEAVY [] 0")
    for name in COMMANDS:
        assert f"\n    {name}" in out
    ran = subprocess.run(
        [sys.executable, "-m", "dexlfd", "learn", "--help"], capture_output=True, text=True
    )
    assert ran.returncode == 0 and "--exclude-outliers" in ran.stdout


def _help_in_fresh_interpreter(argv: list[str], heavy: tuple[str, ...]) -> str:
    """``dexlfd ARGV`` in a fresh interpreter: its output, then ``HEAVY [loaded] code``, the
    modules of ``heavy`` it imported and its exit code."""
    import subprocess
    import sys

    probe = (
        "import sys\n"
        "from dexlfd.cli import main\n"
        f"try:\n    main({argv!r})\nexcept SystemExit as e:\n    code = e.code\n"
        f"heavy = sorted(m for m in {heavy!r} if m in sys.modules)\n"
        "print('HEAVY', heavy, code)\n"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return done.stdout


def test_plan_help_imports_neither_numba_nor_scipy() -> None:
    """``dexlfd plan --help`` reads PlanConfig's and DmpConfig's flags, not the DMP kernels."""
    out = _help_in_fresh_interpreter(["plan", "--help"], ("scipy", "numba"))
    assert "--dmp-basis" in out and "--dmp" in out
    assert out.strip().endswith("HEAVY [] 0")
    # the package's names still import on use, a function named like its module included
    import dexlfd.plan as plan_pkg
    from dexlfd.plan import DmpConfig, PlanConfig, forcing, grasp_schedule

    assert callable(forcing) and callable(grasp_schedule) and plan_pkg.forcing is forcing
    assert PlanConfig().dmp == DmpConfig()
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        _ = plan_pkg.nonexistent
    # the three spellings of the package's names (for type checkers, on use, __all__) agree
    assert sorted(plan_pkg.__all__) == sorted(plan_pkg._EXPORTS)
    assert all(getattr(plan_pkg, name) is not None for name in plan_pkg.__all__)


@pytest.mark.parametrize(
    "command",
    ["demo", "learn", "synth", "export", "plan", "simulate", "experiment", "record", "teleop",
     "calibrate"],
)  # fmt: skip
def test_a_command_parsed_alone_has_the_flags_of_the_full_parser(command: str) -> None:
    from dexlfd.cli import _build_parser

    def flags(parser) -> set[str]:
        sub = next(a for a in parser._actions if a.dest == "command")
        return {o for a in sub.choices[command]._actions for o in a.option_strings}

    from dexlfd.cli import COMMANDS

    assert command in COMMANDS
    assert flags(_build_parser(only=command)) == flags(_build_parser())


def test_usage_errors_are_one_line_and_every_subcommand_describes_itself(capsys) -> None:
    """A bad choice is one line naming the choices (no usage block); `--help` opens with
    a description for every subcommand."""
    from dexlfd.cli import COMMANDS

    with pytest.raises(SystemExit) as exc:
        main(["simulate", "p.npz", "-o", "r.npz", "--controller", "pid"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "invalid choice: 'pid'" in err[0] and "ntsm-pd" in err[0]
    for name in COMMANDS:
        with pytest.raises(SystemExit):
            main([name, "--help"])
        out = capsys.readouterr().out.split("\n\n")
        assert out[1].strip() and not out[1].startswith(("positional", "options")), name


def test_a_position_in_millimetres_gets_a_unit_hint() -> None:
    from dexlfd.panda import workspace_violation

    _, why = workspace_violation(np.array([500.0, -200.0, 120.0]))
    assert "beyond its reach" in why and "did you mean 0.5,-0.2,0.12" in why
    _, why = workspace_violation(np.array([1.2, 0.0, 0.3]))
    assert "millimetres" not in why
