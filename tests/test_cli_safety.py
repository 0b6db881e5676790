"""Regression tests: never lose a user's data, never hang.

One test (or parametrized case) per defect the issue lists; each checks the exit code, that
the message names the flag or file, and that no input was replaced.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import _build_parser, main
from dexlfd.control.loop_config import LoopConfig
from dexlfd.errors import InvalidInput
from dexlfd.io import load_demonstration, load_model, load_plan, save_demonstration
from dexlfd.learn import LearnConfig
from dexlfd.plan import PlanConfig
from dexlfd.plan.teleop import TeleopConfig
from dexlfd.robot.plant import PlantConfig


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Three synthetic demos, a model learned from them and a plan of it (made once)."""
    root = tmp_path_factory.mktemp("safety")
    assert main(["synth", "-n", "3", "--seed", "2", "-o", str(root / "demos")]) == 0
    demos = sorted((root / "demos").glob("demo_*.npz"))
    assert main(["learn", *map(str, demos), "-o", str(root / "m.npz"), "--k", "3"]) == 0
    assert main(["plan", str(root / "m.npz"), "-o", str(root / "p.npz"), "--rate-hz", "200"]) == 0
    video = root / "h.mp4"
    video.write_bytes(b"\x00\x00\x00\x18ftypmp42 not really a video")
    return {
        "demos": root / "demos", "model": root / "m.npz", "plan": root / "p.npz", "video": video
    }  # fmt: skip


def _fails(argv: list[str], capsys: pytest.CaptureFixture[str], *needles: str) -> str:
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in err, err
    return err


def _usage_error(argv: list[str], capsys: pytest.CaptureFixture[str], *needles: str) -> str:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    for needle in needles:
        assert needle in err, err
    return err


# --------------------------------------------------------------------------- data loss


def test_record_output_onto_its_input_video_is_refused(files, capsys) -> None:
    video = files["video"]
    before = _digest(video)
    _fails(["record", str(video), "-o", str(video)], capsys, "-o/--output", "is the input")
    _fails(["record", str(video), "-o", str(video.with_suffix(".txt"))], capsys,
           "-o/--output", "must end in .npz")  # fmt: skip
    out = video.with_name("d.npz")
    _fails(["record", str(video), "-o", str(out), "--overlay", str(video)], capsys,
           "--overlay", "is the input")  # fmt: skip
    _fails(["teleop", str(video), "--video", str(video)], capsys, "--video", "is the input")
    assert _digest(video) == before and not out.exists()


def test_a_link_to_the_input_is_the_input(files, tmp_path: Path, capsys) -> None:
    video = files["video"]
    link = tmp_path / "link.mp4"
    link.symlink_to(video)
    hard = tmp_path / "hard.mp4"
    os.link(video, hard)
    for alias in (link, hard):
        _fails(["teleop", str(video), "--video", str(alias)], capsys, "the same file")


@pytest.mark.parametrize(
    ("argv", "needles"),
    [
        (["export", "{plan}", "--format", "csv", "-o", "{plan}"], ["is the input"]),
        (["export", "{plan}", "--format", "csv", "-o", "{model}"], ["must end in .csv"]),
        (["export", "{plan}", "-o", "{plan}"], ["-o/--output", "is the input"]),
        (["learn", "{d0}", "{d1}", "{d2}", "-o", "{d2}"], ["-o/--output", "is the input"]),
        (["plan", "{model}", "-o", "{model}"], ["-o/--output", "is the input"]),
        (["simulate", "{plan}", "-o", "{plan}"], ["-o/--output", "is the input"]),
        (["experiment", "payload", "--plan", "{plan}", "--json", "{plan}"], ["--json"]),
    ],
)
def test_an_input_is_never_turned_into_another_file(files, capsys, argv, needles) -> None:
    demos = sorted(files["demos"].glob("demo_*.npz"))
    names = {"plan": files["plan"], "model": files["model"],
             **{f"d{i}": p for i, p in enumerate(demos)}}  # fmt: skip
    before = {p: _digest(p) for p in [files["plan"], files["model"], *demos]}
    _fails([a.format(**names) for a in argv], capsys, *needles)
    assert {p: _digest(p) for p in before} == before


def test_two_outputs_of_one_run_may_not_collide(files, tmp_path: Path, capsys) -> None:
    same = tmp_path / "same.mp4"
    _fails(["simulate", str(files["plan"]), "-o", str(same), "--video", str(same)], capsys,
           "-o/--output", "must end in .npz")  # fmt: skip
    (tmp_path / "a").mkdir()
    (tmp_path / "b").symlink_to(tmp_path / "a")
    from dexlfd._commands._outputs import check_outputs
    from dexlfd.errors import InvalidInput

    with pytest.raises(InvalidInput, match="--video and --other both name"):
        check_outputs([("--video", tmp_path / "a" / "x.mp4", ".mp4"),
                       ("--other", tmp_path / "b" / "x.mp4", ".mp4")])  # fmt: skip
    assert not (tmp_path / "d.npz").exists()


@pytest.mark.parametrize(
    ("command", "name"),
    [("plan", "plan.txt"), ("simulate", "rollout.csv"), ("teleop", "t.npy")],
)
def test_suffix_must_match_the_format_written(files, tmp_path, capsys, command, name) -> None:
    src = {"plan": files["model"], "simulate": files["plan"], "teleop": files["video"]}[command]
    _fails([command, str(src), "-o", str(tmp_path / name)], capsys,
           "-o/--output", "must end in .npz")  # fmt: skip
    assert not (tmp_path / name).exists()


def test_stopped_run_does_not_replace_a_finished_file(tmp_path: Path) -> None:
    from dexlfd._commands._outputs import partial_path

    out = tmp_path / "r.npz"
    assert partial_path(out) == out
    out.write_bytes(b"finished")
    assert partial_path(out) == tmp_path / "r.partial.npz"


# --------------------------------------------------------------------------- exhaustion


def test_torque_delay_is_bounded_before_any_work(files, tmp_path, capsys) -> None:
    _usage_error(["simulate", str(files["plan"]), "-o", str(tmp_path / "r.npz"),
                  "--torque-delay", "1000000000"], capsys,
                 "--torque-delay", "0..100")  # fmt: skip


def test_learn_window_relative_to_the_demo_length(files, tmp_path, capsys) -> None:
    demos = sorted(map(str, files["demos"].glob("demo_*.npz")))
    out = tmp_path / "m.npz"
    _usage_error(["learn", *demos, "-o", str(out), "--window", "100000"], capsys, "--window")
    n = min(load_demonstration(p).n_samples for p in demos)
    _fails(["learn", *demos, "-o", str(out), "--window", str(n // 2 + 1)], capsys,
           "error: --window: ", f"window {n // 2 + 1} must be at most half")  # fmt: skip
    assert not out.exists()


@pytest.mark.parametrize(
    ("argv", "flag"),
    [
        (["teleop", "{video}", "--reach-radius", "100"], "--reach-radius"),
        (["teleop", "{video}", "--render-width-px", "2000"], "--render-width-px"),
        (["teleop", "{video}", "--render-height-px", "4000"], "--render-height-px"),
        (["demo", "--workers", "0"], "--workers"),
        (["experiment", "payload", "--workers", "0"], "--workers"),
        (["synth", "-o", "x", "--seed", str(2**40)], "--seed"),
        (["simulate", "{plan}", "-o", "r.npz", "--payload", "50"], "--payload"),
        (["simulate", "{plan}", "-o", "r.npz", "--model-error", "nan"], "--model-error"),
        (["plan", "{model}", "-o", "p.npz", "--rate-hz", "1e9"], "--rate-hz"),
        (["learn", "{model}", "-o", "m.npz", "--n-query", "100000000"], "--n-query"),
    ],
)
def test_numeric_flags_are_bounded_at_parse_time(files, capsys, argv, flag) -> None:
    names = {k: str(v) for k, v in files.items()}
    err = _usage_error([a.format(**names) for a in argv], capsys, flag)
    assert "expected" in err  # the accepted range is in the message


def test_demo_workers_0_is_refused_before_any_work(tmp_path: Path, capsys) -> None:
    _usage_error(["demo", "-o", str(tmp_path / "out"), "--workers", "0"], capsys, "1..64")
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------- nonsense


def _with(demo, **arrays):
    import dataclasses

    return dataclasses.replace(demo, **arrays)


def test_negative_gripper_opening_names_the_file(files, tmp_path, capsys) -> None:
    demo = load_demonstration(next(files["demos"].glob("demo_*.npz")))
    bad = _with(demo, gripper=demo.gripper - 5.0)._write(tmp_path / "neg.npz")  # unchecked
    _fails(["learn", str(bad), "-o", str(tmp_path / "m.npz")], capsys,
           str(bad), "gripper opening down to")  # fmt: skip
    plan = load_plan(files["plan"])
    bad_plan = _with(plan, gripper=plan.gripper - 5.0)._write(tmp_path / "neg_plan.npz")
    _fails(["simulate", str(bad_plan), "-o", str(tmp_path / "r.npz")], capsys,
           str(bad_plan), "gripper opening")  # fmt: skip


def test_milliseconds_and_scaled_positions_name_the_file(files, tmp_path, capsys) -> None:
    demo = load_demonstration(next(files["demos"].glob("demo_*.npz")))
    ms = _with(demo, t=demo.t * 1000.0)._write(tmp_path / "ms.npz")  # unchecked
    _fails(["learn", str(ms), "-o", str(tmp_path / "m.npz")], capsys, str(ms), "milliseconds")
    far = _with(demo, position=demo.position * 1e200, keypoints=demo.keypoints * 1e200)._write(
        tmp_path / "far.npz"
    )
    err = _fails(["learn", str(far), "-o", str(tmp_path / "m.npz")], capsys, str(far), "metres")
    assert "overflow" not in err


def test_identical_demonstrations_are_named(files, tmp_path, capsys) -> None:
    demos = sorted(files["demos"].glob("demo_*.npz"))
    copy = tmp_path / "copy.npz"
    shutil.copy(demos[0], copy)
    argv = ["learn", str(demos[0]), str(demos[1]), str(copy), "-o", str(tmp_path / "m.npz")]
    assert main([*argv, "--k", "3"]) == 0
    err = capsys.readouterr().err
    assert f"{copy} is identical to {demos[0]}" in err


def test_synth_refuses_a_folder_with_other_demos_and_records_its_seed(tmp_path, capsys) -> None:
    out = tmp_path / "d"
    assert main(["synth", "-n", "3", "--seed", "7", "-o", str(out)]) == 0
    meta = load_demonstration(out / "demo_01.npz").meta
    assert (meta["seed"], meta["index"], meta["n_demos"]) == (7, 1, 3)
    _fails(["synth", "-n", "2", "-o", str(out)], capsys, "demo_02.npz", "would mix it in")
    assert main(["synth", "-n", "3", "--seed", "8", "-o", str(out)]) == 0  # same files: fine
    assert load_demonstration(out / "demo_00.npz").meta["seed"] == 8
    recorded = load_demonstration(out / "demo_00.npz")
    save_demonstration(out / "demo_00.npz", _with(recorded, meta={"source": "hand.mp4"}))
    _fails(["synth", "-n", "3", "-o", str(out)], capsys, "not a synthetic demonstration")


# --------------------------------------------------------------------------- messages


@pytest.mark.parametrize(
    ("command", "make", "expected"),
    [
        ("learn", lambda: LearnConfig(n_components=0), "--k must be an integer in 1..50 or auto"),
        ("simulate", lambda: PlantConfig(payload_kg=4.0), "--payload-kg must be in [0, 3] kg"),
        ("simulate", lambda: LoopConfig(torque_delay=-1),
         "--torque-delay-ticks must be an integer in 0..100 ticks, got -1"),
        ("teleop", lambda: TeleopConfig(max_speed=0.0), "--max-speed-mps must be in (0, 1.7] m/s"),
        ("teleop", lambda: TeleopConfig(reach_radius=-1.0), "--reach-radius-m must be in"),
        ("plan", lambda: PlanConfig(goal_quat=(0, 0, 0, 3)), "--goal-quat must be a unit"),
        ("plan", lambda: PlanConfig(margin=2.0), "--margin-m must be in [0, 1] m, got 2.0"),
    ],
)  # fmt: skip
def test_config_errors_name_the_flag_not_the_field(command: str, make, expected: str) -> None:
    """A config's own range check names the field; the command line shows its flag."""
    from dexlfd.cli import _subparser, error_text

    with pytest.raises(InvalidInput) as err:
        make()
    flags = _subparser(_build_parser(), command).get_default("_params")
    assert error_text(err.value, flags).startswith(expected)


def test_teleop_config_errors_reach_the_user_as_flags(files, capsys) -> None:
    _usage_error(["teleop", str(files["video"]), "--max-speed-mps", "0", "-o", "t.npz"], capsys,
                 "--max-speed-mps: expected a number in (0, 1.7] m/s")  # fmt: skip


FLAGS_WITH_UNITS = {
    "simulate": ["--torque-delay", "--payload", "--model-error", "--seed", "--video", "--plot"],
    "teleop": ["--render-width-px", "--render-height-px", "--reach-radius", "--scale", "--seed"],
    "learn": ["--k", "--window", "--n-query", "--seed", "--max-gap-s", "--band-fraction"],
    "plan": ["--duration-s", "--rate-hz", "--margin-m", "--influence-m"],
    "demo": ["--workers", "--seed"],
    "experiment": ["--workers", "--seed", "--duration-s", "--model-error"],
    "synth": ["-n", "--seed"],
}


@pytest.mark.parametrize("command", sorted(FLAGS_WITH_UNITS))
def test_help_gives_range_and_default(command: str) -> None:
    parser = _build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    p = sub.choices[command]  # type: ignore[index]
    for action in p._actions:
        if not set(action.option_strings) & set(FLAGS_WITH_UNITS[command]):
            continue
        text = action.help or ""
        if action.option_strings[-1] in ("--video", "--plot"):
            assert ".mp4" in text or ".png" in text, (command, action.option_strings)
            continue
        assert "default" in text, (command, action.option_strings, text)
        assert ".." in text or "]" in text, (command, action.option_strings, text)


def test_every_np_load_refuses_pickles() -> None:
    root = Path(__file__).resolve().parents[1]
    calls = []
    for folder in ("src", "tests", "benchmarks", "examples"):
        for path in (root / folder).rglob("*.py"):
            for i, line in enumerate(path.read_text().splitlines()):
                if "np.load(" in line and "allow_pickle=False" not in line:
                    calls.append(f"{path.relative_to(root)}:{i + 1}")
    assert calls == []


def test_model_file_round_trip_is_kept_by_loader(files) -> None:
    # the plausibility checks accept what the pipeline writes
    model = load_model(files["model"])
    assert model.n_samples > 10
    assert json.loads(json.dumps(model.meta))
    assert np.isfinite(model.mean).all()


@pytest.mark.slow
@pytest.mark.skipif(
    not os.environ.get("DEXLFD_REALTIME_TESTS"),
    reason="needs real time: the SIGINT must land while the run is writing its video, which "
    "a busy CI host cannot guarantee (under a CPU hog the whole run finished first); run with "
    "DEXLFD_REALTIME_TESTS=1",
)
def test_ctrl_c_during_teleop_video_keeps_the_rollout(tmp_path: Path, hand_video: Path) -> None:
    """Ctrl-C reaches the whole foreground process group, as from a terminal."""
    import signal
    import subprocess
    import sys
    import time

    out, video = tmp_path / "t.npz", tmp_path / "t.mp4"
    # the whole 621-frame video, interrupted as soon as the video writer has started (its
    # temporary file exists): under load ffmpeg may write its first bytes only at the end,
    # so waiting for bytes let the run finish first. The lift is the constant-depth one:
    # this test is about Ctrl-C, not about the teleop's shaping of the PnP depth.
    cmd = [sys.executable, "-m", "dexlfd.cli", "teleop", str(hand_video), "--lift", "assumed_depth",
           "--resize-width-px", "320", "-o", str(out), "--video", str(video),
           "--render-width-px", "96", "--render-height-px", "64"]  # fmt: skip
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path), "MUJOCO_GL": "egl"}
    proc = subprocess.Popen(cmd, start_new_session=True, stderr=subprocess.PIPE, text=True, env=env)
    part = tmp_path / ".t.mp4.part.mp4"  # exists once the first frames go to the encoder
    try:
        while not part.exists() and proc.poll() is None:
            time.sleep(0.1)
        assert proc.poll() is None, proc.communicate()[1]
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=600)  # a guard against a hang, not a speed check
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "ffmpeg exit" not in err
    from dexlfd.io import load_rollout

    assert load_rollout(out).n_samples > 0 and video.stat().st_size > 0
    assert not part.exists()


def test_render_bounds_are_the_offscreen_buffer_of_the_simulated_panda() -> None:
    from dexlfd._commands.teleop import MAX_RENDER_PX
    from dexlfd.panda import Q_READY
    from dexlfd.robot.plant import PlantConfig
    from dexlfd.robot.sim import PandaSim

    with PandaSim(PlantConfig(), Q_READY) as sim:
        g = sim.model.vis.global_
        assert (g.offwidth, g.offheight) == MAX_RENDER_PX
