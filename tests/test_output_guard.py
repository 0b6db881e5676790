"""One output guard for every command: no input of the run is replaced, whichever flag named
it, and no file a command places in an output folder replaces one dexlfd did not write."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

from dexlfd._commands._outputs import (
    LEDGER,
    check_folder_files,
    record_written,
    source_files,
)
from dexlfd.cli import main
from dexlfd.errors import InvalidInput


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def inputs(tmp_path: Path) -> dict[str, Path]:
    np.save(tmp_path / "pose.npy", np.eye(4))
    np.save(tmp_path / "K.npy", np.array([500.0, 500.0, 320.0, 240.0]))
    for name in ("top.mp4", "side.mp4", "img.png"):
        (tmp_path / name).write_bytes(b"\x00not really media " + name.encode())
    return {p.stem: p for p in tmp_path.iterdir()}


def _refused(argv: list[str], capsys, flag: str, victim: Path) -> None:
    before = _digest(victim)
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and flag in err and "input" in err, err
    assert _digest(victim) == before


@pytest.mark.parametrize(
    ("argv", "flag", "victim"),
    [
        (["calibrate", "{img}", "--board", "checkerboard:9x6,0.025", "--board-pose", "{pose}",
          "-o", "{pose}"], "-o/--output", "pose"),
        (["calibrate", "{img}", "--board", "checkerboard:9x6,0.025", "--board-pose", "{pose}",
          "--intrinsics", "{K}", "-o", "{K}"], "-o/--output", "K"),
        (["record", "videos:{top},{side}", "-o", "{dir}/r.npz", "--overlay", "{top}"],
         "--overlay", "top"),
        (["teleop", "videos:{top},{side}", "--video", "{side}"], "--video", "side"),
        (["teleop", "{top}", "--extrinsics", "{pose}", "-o", "{dir}/t.npz", "--video",
          "{dir}/v.mp4", "--rerun", "{pose}"], "--rerun", "pose"),
    ],
)  # fmt: skip
def test_no_output_is_an_input_whichever_flag_named_it(
    inputs, tmp_path: Path, capsys, argv, flag, victim
) -> None:
    names = {k: str(v) for k, v in inputs.items()} | {"dir": str(tmp_path)}
    _refused([a.format(**names) for a in argv], capsys, flag, inputs[victim])


def test_two_camera_sources_name_both_files() -> None:
    assert source_files("videos:a.mp4, b.mp4") == ["a.mp4", "b.mp4"]
    assert source_files("clip.mp4") == ["clip.mp4"]


def test_experiment_does_not_replace_a_users_figure(tmp_path: Path, capsys) -> None:
    ex = tmp_path / "ex"
    ex.mkdir()
    mine = ex / "payload_lift_z.png"
    mine.write_bytes(b"my own figure")
    assert main(["experiment", "payload", "-o", str(ex), "--workers", "1"]) == 1
    err = capsys.readouterr().err
    assert "payload_lift_z.png" in err and "--overwrite" in err and "-o/--output" in err
    assert mine.read_bytes() == b"my own figure"
    gen = tmp_path / "gen"
    gen.mkdir()
    (gen / "generalize.txt").write_text("my notes")
    model = tmp_path / "m.npz"
    model.write_bytes(b"unread: refused before loading")
    assert main(["experiment", "generalize", str(model), "-o", str(gen)]) == 1
    assert "generalize.txt" in capsys.readouterr().err
    assert (gen / "generalize.txt").read_text() == "my notes"


def test_experiment_payload_refuses_a_model_it_would_ignore(tmp_path: Path, capsys) -> None:
    model = tmp_path / "m.npz"
    model.write_bytes(b"x")
    assert main(["experiment", "payload", str(model), "-o", str(tmp_path / "ex")]) == 1
    err = capsys.readouterr().err
    assert "takes no MODEL" in err and "--plan" in err


def test_demo_does_not_write_into_a_folder_of_someone_elses_files(tmp_path: Path, capsys) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "model.npz").write_bytes(b"the user's model")
    assert main(["demo", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "model.npz" in err and "--overwrite" in err
    assert (out / "model.npz").read_bytes() == b"the user's model"


def test_a_file_dexlfd_wrote_may_be_replaced_until_someone_edits_it(tmp_path: Path) -> None:
    fig = tmp_path / "a.png"
    fig.write_bytes(b"v1")
    with pytest.raises(InvalidInput, match="a.png exists and was not written there"):
        check_folder_files("-o/--output", tmp_path, ["a.png"])
    record_written(tmp_path, [fig])
    assert (tmp_path / LEDGER).is_file()
    check_folder_files("-o/--output", tmp_path, ["a.png", "b.png"])  # ours, unchanged
    fig.write_bytes(b"edited by hand")
    with pytest.raises(InvalidInput, match="--overwrite"):
        check_folder_files("-o/--output", tmp_path, ["a.png"])
    check_folder_files("-o/--output", tmp_path, ["a.png"], overwrite=True)


@pytest.mark.parametrize(
    "argv",
    [
        ["learn", "{bad}", "-o", "{tmp}/m.npz", "--plot", "{out}/figs"],
        ["plan", "{bad}", "-o", "{tmp}/p.npz", "--plot", "{out}/figs"],
        ["simulate", "{bad}", "-o", "{tmp}/r.npz", "--plot", "{out}/figs"],
        ["record", "{bad}", "-o", "{out}/demos/"],
        ["record", "{bad}", "{tmp}/worse.npz", "-o", "{out}/demos/", "--overlay", "{out}/ov/"],
        ["record", "{bad}", "-o", "{tmp}/d.npz", "--plot", "{out}/plots"],
        ["record", "{bad}", "{tmp}/worse.npz", "-o", "{out}/d/", "--save-landmarks", "{out}/lm/"],
        ["experiment", "generalize", "{bad}", "-o", "{out}/gen"],
        ["teach", "{bad}", "-o", "{out}/teach"],
    ],
    ids=lambda argv: "-".join(a for a in argv if a.startswith("-") or a.isalpha()),
)
def test_a_refused_command_leaves_no_output_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    """The output folders are checked first but made only for a run that gets under way."""
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip file")
    (tmp_path / "worse.npz").write_bytes(b"not a zip file either")
    out = tmp_path / "new" / "deeper"
    args = [a.format(bad=bad, tmp=tmp_path, out=out) for a in argv]
    assert main([*args, "-q"]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and str(bad) in err, err
    assert not (tmp_path / "new").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.npz", "worse.npz"]


@pytest.mark.parametrize("name", ["out.txt", "figs.avi", "plots.png"])
def test_a_new_folder_named_like_a_file_is_refused(tmp_path: Path, name: str) -> None:
    """``--plot out.txt`` would make a folder one takes for a text file: said, not made."""
    from dexlfd._commands._outputs import DIR, check_outputs

    with pytest.raises(InvalidInput, match=f"--plot {tmp_path / name}: expected a folder name"):
        check_outputs([("--plot", tmp_path / name, DIR)])
    assert list(tmp_path.iterdir()) == []
    (tmp_path / name).mkdir()  # an existing folder of that name is the user's choice
    assert check_outputs([("--plot", tmp_path / name, DIR)]) == [tmp_path / name]
