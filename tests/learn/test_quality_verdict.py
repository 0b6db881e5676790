"""learn says when an input's own verdict is NOT usable and when no outlier test ran (item 5)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from dexlfd.cli import main
from dexlfd.datasets import pick_place_demonstrations
from dexlfd.io import load_model, save_demonstration
from dexlfd.io.demonstration_facts import Quality


def _files(tmp_path: Path, n: int, bad: int | None) -> list[Path]:
    demos = pick_place_demonstrations(n, np.random.default_rng(7))
    out = []
    for i, d in enumerate(demos):
        if i == bad:
            q = Quality(usable=False, warnings=("hand lost: seen in 73 % of frames",))
            d = dataclasses.replace(d, quality=q)
        elif i == 0:
            d = dataclasses.replace(d, quality=Quality(usable=True))
        out.append(save_demonstration(tmp_path / f"demo_{i}.npz", d))
    return out


def test_unusable_input_is_named_and_two_demos_print_the_note(tmp_path: Path, capsys) -> None:
    files = _files(tmp_path, 2, bad=1)
    out = tmp_path / "m.npz"
    assert main(["learn", *map(str, files), "-o", str(out), "--k", "3", "--window", "3"]) == 0
    err = capsys.readouterr().err
    (line,) = [ln for ln in err.splitlines() if "NOT usable" in ln]
    assert line.startswith("W ") and str(files[1]) in line and "hand lost" in line
    assert str(files[0]) not in line
    assert "robust z" not in err  # no z-scores shown: the test did not run
    assert "outlier test: 2 demonstration(s): at least 4 are needed to flag outliers" in err
    assert load_model(out).meta["unusable_demonstrations"] == [str(files[1])]


def test_four_usable_demos_show_z_scores_and_no_verdict_warning(tmp_path: Path, capsys) -> None:
    files = _files(tmp_path, 4, bad=None)
    out = tmp_path / "m.npz"
    assert main(["learn", *map(str, files), "-o", str(out), "--k", "3", "--window", "3"]) == 0
    err = capsys.readouterr().err
    assert err.count("robust z") == 4
    assert "NOT usable" not in err and "outlier test:" not in err
    assert load_model(out).meta["unusable_demonstrations"] == []
