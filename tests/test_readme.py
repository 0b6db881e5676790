"""Every shell command of README.md is run (or listed here as skipped, with the reason).

The README's ``sh``/``bash`` blocks are parsed (continuation lines joined, comments
dropped); each block runs in its own empty folder, command after command, through
``bash`` with ``dexlfd`` and ``python`` meaning this interpreter. The files a block
reads before it writes them (``hand.mp4``, ``model.npz``, ``plan.npz``, ...) are made
once per session from the packaged samples: the videos are the real pick-and-place that
ships in ``dexlfd.data`` (every second frame, to halve the tracking time; the
walk-through's ``teach`` runs on the packaged file itself), ``table.jpg`` is the
ChArUco board ``dexlfd calibrate --print-board`` draws, and the pipeline files come
from ``dexlfd synth``/``learn``/``plan``/``simulate``.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"

#: commands not run here, each with the reason (matched by regular expression)
SKIPPED: dict[str, str] = {
    r"^pip install": "installs from the package index; the wheel tests install the checkout",
    r"^make demo\b": "is `dexlfd demo -o dexlfd-demo`, which runs here",
    r"^make test\b": "is the test suite itself",
    r"\brealsense\b": "needs a RealSense camera",
    r"\brec\.db3\b": "needs a RealSense recording (none ships with the package)",
    r"\bwebcams?:\d": "needs webcams",
    r"\bvideos:\S+,": "needs two videos filmed together of one hand (none ships)",
    r"--ray-address auto": "needs a running Ray cluster",
    r"franka://": "needs a Franka arm",
    r"franky-sim|bench_franka\.py": (
        "needs the Franka-protocol simulator's own environment (`make franka-sim`); "
        "tests/robot/test_franka.py runs it"
    ),
    r"^ros2 ": "needs a ROS 2 installation",
}

#: sizes cut for the test (the command is otherwise run as written)
SHRUNK: dict[str, str] = {
    "--trials 64": "--trials 2",  # a Monte-Carlo study of 2 trials, not 64
    "--pairs 25": "--pairs 2",  # a generalize grid of 2 pairs, not 25
}

#: commands another test runs as written and checks output by output (run once per suite)
ELSEWHERE = {r"^dexlfd demo -o \S+$": "tests/apps/test_demo.py"}

VIDEOS = ("hand.mp4", "take1.mp4", "take2.mp4", "a.mp4", "b.mp4", "c.mp4", "videos")
PIPELINE = ("demos", "model.npz", "plan.npz", "rollout.npz")
CAMERA = ("table.jpg", "K.npy", "K.yaml", "T.npy", "camera2base.npy")
OUTPUT_FLAGS = {"-o", "--json", "--overlay", "--save-landmarks", "--video", "--plot"}


def readme_blocks(text: str | None = None) -> list[list[str]]:
    """The commands of each ``sh``/``bash`` block of the README, in order."""
    text = README.read_text() if text is None else text
    blocks = []
    for body in re.findall(r"```(?:sh|bash)\n(.*?)```", text, re.S):
        commands = []
        for line in body.replace("\\\n", " ").splitlines():
            command = _strip_comment(line).strip()
            if command:
                commands.append(re.sub(r"\s+", " ", command))
        blocks.append(commands)
    return blocks


def _strip_comment(line: str) -> str:
    """The line without its trailing ``# comment`` (a ``#`` inside quotes stays)."""
    quote = None
    for i, ch in enumerate(line):
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i]
    return line


def skip_reason(command: str) -> str | None:
    """Why ``command`` is not run here (None: it runs)."""
    for pattern, test in ELSEWHERE.items():
        if re.search(pattern, command):
            return f"{test} runs it as written and checks its outputs"
    for pattern, reason in SKIPPED.items():
        if re.search(pattern, command):
            return reason
    return None


def _shrink(command: str) -> str:
    for full, small in SHRUNK.items():
        command = command.replace(full, small)
    return command


def _names(command: str) -> tuple[set[str], set[str]]:
    """(files the command names, files it writes), first path component, no trailing /."""
    tokens = command.replace('"', " ").split()
    named, written = set(), set()
    for prev, tok in zip(["", *tokens], tokens, strict=False):
        name = tok.split("/")[0] if "/" in tok else tok
        named.add(name)
        if prev in OUTPUT_FLAGS:
            written.add(name)
    return named, written


def _inputs_of(block: list[str]) -> set[str]:
    """The sample/pipeline files a block reads before any of its commands writes them."""
    known = set(VIDEOS + PIPELINE + CAMERA)
    needed: set[str] = set()
    written: set[str] = set()
    for command in block:
        if skip_reason(command):
            continue
        named, out = _names(command)
        needed |= (named & known) - written - out
        written |= out
    return needed


def test_readme_is_parsed_into_its_commands() -> None:
    text = "x\n```sh\ndexlfd a b \\\n    --c 1   # note\n# only a comment\n\ndexlfd d\n```\n"
    assert readme_blocks(text) == [["dexlfd a b --c 1", "dexlfd d"]]
    assert _strip_comment('dexlfd teach "$(python -m x)" -o t/   # then #2') == (
        'dexlfd teach "$(python -m x)" -o t/   '
    )
    assert _inputs_of(["dexlfd synth -o demos/", "dexlfd learn demos/*.npz -o model.npz"]) == set()
    assert _inputs_of(["dexlfd simulate plan.npz -o rollout.npz"]) == {"plan.npz"}


def test_every_readme_command_is_run_or_skipped_with_a_reason() -> None:
    commands = [c for block in readme_blocks() for c in block]
    assert len(commands) > 40
    runners = ("dexlfd ", "python ", "pip ", "make ", "ros2 ", "ROS_DOMAIN_ID=")
    for command in commands:
        assert command.startswith(runners), f"README command of an unknown kind: {command}"
        if not command.startswith(("dexlfd ", "ROS_DOMAIN_ID=")):
            assert skip_reason(command), f"no reason to skip {command!r}"
    # the walk-through from the bundled video to the robot runs
    assert any(c.startswith("dexlfd teach") and "dexlfd.data" in c for c in commands)
    assert all(any(re.search(p, c) for c in commands) for p in ELSEWHERE)
    assert all((REPO / test).is_file() for test in ELSEWHERE.values())
    assert all(p in " ".join(commands) for p in SHRUNK), "a shrunk flag left the README"


# ---------------------------------------------------------------- running the commands


def _run(argv: list[str] | str, cwd: Path, env: dict[str, str]) -> None:
    """Run one command (a shell line or argv); fail with its last error lines."""
    shell = isinstance(argv, str)
    done = subprocess.run(
        ["bash", "-c", argv] if shell else argv,
        cwd=cwd, env=env, capture_output=True, text=True, check=False, timeout=3600,
    )  # fmt: skip
    if done.returncode != 0:
        tail = "\n".join(done.stderr.strip().splitlines()[-8:])
        pytest.fail(f"`{argv}` exited {done.returncode} in {cwd}:\n{tail}")


@pytest.fixture(scope="module")
def readme_env(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """PATH with ``dexlfd`` and ``python`` running this interpreter and this source."""
    bin_dir = tmp_path_factory.mktemp("bin")
    for name, body in (("dexlfd", '-m dexlfd "$@"'), ("python", '"$@"')):
        script = bin_dir / name
        script.write_text(f'#!/bin/sh\nexec "{sys.executable}" {body}\n')
        script.chmod(0o755)
    env = dict(os.environ)
    env["PATH"] = f"{bin_dir}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = os.pathsep.join([str(REPO / "src"), *filter(None, [env.get("PYTHONPATH")])])
    env.setdefault("MPLBACKEND", "Agg")
    return env


def _every_second_frame(src: Path, dst: Path, first: int) -> None:
    import cv2

    cap = cv2.VideoCapture(str(src))
    fps = cap.get(cv2.CAP_PROP_FPS)
    writer = None
    index = 0
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            if index % 2 == first:
                if writer is None:
                    size = (frame.shape[1], frame.shape[0])
                    writer = cv2.VideoWriter(
                        str(dst), cv2.VideoWriter_fourcc(*"mp4v"), fps / 2, size
                    )
                writer.write(frame)
            index += 1
    finally:
        cap.release()
        if writer is not None:
            writer.release()


@pytest.fixture(scope="module")
def readme_inputs(tmp_path_factory: pytest.TempPathFactory, readme_env) -> Path:
    """The files README commands read, made once from the packaged samples."""
    import numpy as np

    from dexlfd.data import pick_place_video

    folder = tmp_path_factory.mktemp("readme_inputs")
    video = pick_place_video()
    _every_second_frame(video, folder / "take1.mp4", 0)
    _every_second_frame(video, folder / "take2.mp4", 1)
    for name in ("hand.mp4", "a.mp4", "b.mp4", "c.mp4"):
        shutil.copy2(folder / "take1.mp4", folder / name)
    (folder / "videos").mkdir()
    for name in ("take1.mp4", "take2.mp4"):
        shutil.copy2(folder / name, folder / "videos" / name)
    # a 60 deg camera of the 640x360 samples
    fx = 320 / np.tan(np.radians(30))
    k = np.array([[fx, 0, 320], [0, fx, 180], [0, 0, 1]])
    np.save(folder / "K.npy", k)
    import cv2

    fs = cv2.FileStorage(str(folder / "K.yaml"), cv2.FILE_STORAGE_WRITE)
    fs.write("camera_matrix", k)
    fs.release()
    steps = [
        "dexlfd calibrate --print-board board.png --board charuco:7x5,0.035,0.026",
        "cp board.png table.jpg",
        "dexlfd calibrate table.jpg --board charuco:7x5,0.035,0.026 "
        "--board-pose 0.4,-0.12,0,0,0,90 -o T.npy",
        "cp T.npy camera2base.npy",
        "dexlfd synth -n 6 -o demos/",
        "dexlfd learn demos/*.npz -o model.npz",
        "dexlfd plan model.npz -o plan.npz",
        "dexlfd simulate plan.npz -o rollout.npz",
    ]
    for step in steps:
        _run(step, folder, readme_env)
    return folder


def _runnable_blocks() -> list[int]:
    return [i for i, b in enumerate(readme_blocks()) if any(not skip_reason(c) for c in b)]


@pytest.mark.slow
@pytest.mark.integration
@pytest.mark.parametrize("index", _runnable_blocks())
def test_readme_block_runs(index: int, tmp_path: Path, readme_inputs: Path, readme_env) -> None:
    """Each command of the block exits 0 in an empty folder with the files it reads."""
    block = readme_blocks()[index]
    for name in _inputs_of(block):
        src = readme_inputs / name
        (shutil.copytree if src.is_dir() else shutil.copy2)(src, tmp_path / name)
    ran = 0
    for command in block:
        if skip_reason(command):
            continue
        _run(_shrink(command), tmp_path, readme_env)
        ran += 1
    assert ran > 0
