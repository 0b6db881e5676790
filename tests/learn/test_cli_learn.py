from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.datasets import pick_place_demonstrations
from dexlfd.io import load_model, save_demonstration


@pytest.fixture
def demo_files(tmp_path: Path) -> list[Path]:
    demos = pick_place_demonstrations(4, np.random.default_rng(7))
    return [save_demonstration(tmp_path / f"demo_{i}.npz", d) for i, d in enumerate(demos)]


def test_learn_writes_model_and_figures(demo_files: list[Path], tmp_path: Path, fake_progress):
    import dexlfd._commands.learn as learn

    bars = fake_progress(learn)
    out = tmp_path / "model.npz"
    figs = tmp_path / "figs"
    argv = [*map(str, demo_files), "-o", str(out), "--k", "5", "--window", "5"]
    assert main(["learn", *argv, "--reference", "2", "--plot", str(figs), "-q"]) == 0
    model = load_model(out)
    assert model.meta["n_components"] == 5 and model.meta["settings"]["window"] == 5
    assert int(model.extras["reference_index"]) == 2
    assert model.meta["demonstrations"] == [str(p) for p in demo_files]
    names = sorted(p.name for p in figs.glob("*.png"))
    assert names == [
        "alignment.png",
        "dtw_correspondence.png",
        "dtw_example.png",
        "gmm.png",
        "gmr.png",
        "quality.png",
    ]
    # the EM iterations, then the figures as each is written, on their own bars
    assert [b.desc for b in bars] == ["EM", "figures"] and bars[1].n == 6


def test_truncated_and_foreign_files_are_one_line_errors(
    demo_files: list[Path], tmp_path: Path, capsys
) -> None:
    truncated = tmp_path / "cut.npz"
    truncated.write_bytes(demo_files[0].read_bytes()[:300])
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, a=np.zeros(3))
    for bad in (truncated, foreign, tmp_path / "missing.npz"):
        code = main(["learn", str(demo_files[0]), str(bad), "-o", str(tmp_path / "m.npz"), "-q"])
        err = capsys.readouterr().err
        assert code == 1
        assert err.count("\n") == 1 and str(bad) in err and "Traceback" not in err
    assert not (tmp_path / "m.npz").exists()


def test_bad_arguments(demo_files: list[Path], tmp_path: Path, capsys) -> None:
    files = list(map(str, demo_files))
    with pytest.raises(SystemExit) as exc:
        main(["learn", *files, "-o", str(tmp_path / "m.npz"), "--reference", "best"])
    assert exc.value.code == 2
    assert main(["learn", *files, "-o", str(tmp_path / "m.npz"), "--reference", "9"]) == 1
    assert "--reference index 9 out of range" in capsys.readouterr().err  # the flag, not the field
    for flag, value in (("--k", "0"), ("--band-fraction", "1.5")):
        with pytest.raises(SystemExit) as exc:
            main(["learn", *files, "-o", str(tmp_path / "m.npz"), flag, value])
        assert exc.value.code == 2
        assert f"{flag}: expected" in capsys.readouterr().err
    assert main(["learn", *files, "-o", str(tmp_path / "m.npz"), "--band-fraction", "0.2"]) == 0
    capsys.readouterr()
    assert main(["learn", *files, "-o", str(tmp_path / "m.txt")]) == 1
    assert "-o/--output" in capsys.readouterr().err
    assert main(["learn", *files, "-o", str(tmp_path / "no" / "m.npz")]) == 1
    assert "does not exist" in capsys.readouterr().err


def test_dtw_grid_over_the_bound_is_refused_up_front(
    demo_files: list[Path], tmp_path: Path, capsys, monkeypatch
) -> None:
    """Demonstrations too long to align are refused in one line before any DTW runs."""
    import importlib

    dtw_module = importlib.import_module("dexlfd.learn.dtw")
    monkeypatch.setattr(dtw_module, "MAX_CELLS", 100)  # a 10 x 10 grid

    def no_dtw(*args: object) -> None:
        raise AssertionError("a DTW ran before the refusal")

    monkeypatch.setattr(dtw_module, "_dtw_rows", no_dtw)
    out = tmp_path / "model.npz"
    assert main(["learn", *map(str, demo_files), "-o", str(out), "--k", "3", "-q"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("dexlfd learn: error: ")
    assert "--band-fraction" in err[0] and "demo_" in err[0]
    assert not out.exists()


@pytest.mark.slow  # a subprocess aligning 20,000-sample demonstrations
def test_ctrl_c_interrupts_the_alignment_of_long_demonstrations(tmp_path: Path) -> None:
    """SIGINT while learn aligns long demonstrations: exit 130, one line, no model.

    Two things made this racy. A runner started in the background without job control
    (``make test &`` in a script) ignores SIGINT, and a process that starts with SIGINT
    ignored keeps ignoring it (Python installs no handler then, as a shell's background
    job should): the child gets SIGINT's default disposition here, as a terminal's would.
    And on a loaded machine this process may read the progress line long after it was
    written: the child is frozen (SIGSTOP) while the test looks at what it has done, the
    signal is sent to the frozen child and it resumes (SIGCONT) only then, so whether the
    model existed before the signal is known, not guessed.
    """
    import os
    import signal
    import subprocess
    import sys

    demos = pick_place_demonstrations(3, np.random.default_rng(7))
    paths = [save_demonstration(tmp_path / f"long_{i}.npz", _tiled(d, 20_000)) for i, d in
             enumerate(demos)]  # fmt: skip
    out = tmp_path / "model.npz"
    cmd = [sys.executable, "-m", "dexlfd.cli", "learn", *map(str, paths), "-o", str(out)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen(
        cmd, stderr=subprocess.PIPE, text=True, env=env, preexec_fn=_terminal_sigint
    )
    try:
        assert proc.stderr is not None
        for line in proc.stderr:  # the alignment follows this line
            if "learning from 3 demonstration(s)" in line:
                break
        proc.send_signal(signal.SIGSTOP)
        _wait_stopped(proc.pid)
        finished_before = out.exists()  # frozen: nothing changes until SIGCONT
        proc.send_signal(signal.SIGINT)  # pending until the child runs again
        proc.send_signal(signal.SIGCONT)
        _, err = proc.communicate(timeout=600)  # a guard against a hang, not a speed check
    finally:
        if proc.poll() is None:
            proc.kill()
    if finished_before:  # the model was written before the signal: a finished output
        assert proc.returncode in (0, 130), err
        return
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "dexlfd learn: interrupted; finished outputs are kept"
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [p.name for p in paths]


def _terminal_sigint() -> None:
    """In the child before exec: SIGINT as a terminal's foreground job has it."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _wait_stopped(pid: int) -> None:
    """Return once ``pid`` is stopped (state ``T`` in /proc), or at once without /proc."""
    import time

    stat = Path(f"/proc/{pid}/stat")
    while stat.exists():
        state = stat.read_text().rsplit(")", 1)[1].split()[0]
        if state in ("T", "t", "Z", "X"):
            return
        time.sleep(0.01)


def _tiled(demo, n: int):
    """``demo`` repeated to ``n`` samples at its own frame rate."""
    from dataclasses import fields, replace

    reps = -(-n // demo.n_samples)
    arrays = {
        f.name: np.concatenate([getattr(demo, f.name)] * reps)[:n]
        for f in fields(demo)
        if f.name in demo.SPECS
    }
    arrays["t"] = np.arange(n) * float(np.median(np.diff(demo.t)))
    return replace(demo, **arrays, extras={})
