"""Knobs that multiply work are bounded up front, and a study without a result says so."""

from __future__ import annotations

from pathlib import Path

import pytest

from dexlfd.cli import main
from dexlfd.errors import InvalidInput


def test_plan_rate_below_what_the_loader_accepts_is_a_usage_error(capsys) -> None:
    for rate in ("0.001", "0.5"):
        with pytest.raises(SystemExit) as exc:
            main(["plan", "m.npz", "--rate-hz", rate, "-o", "p.npz"])
        assert exc.value.code == 2
        assert "--rate-hz" in capsys.readouterr().err


def test_generalize_workload_is_estimated_and_bounded(caplog) -> None:
    from dexlfd._commands.experiment import _check_generalize_workload

    caplog.set_level("INFO", logger="dexlfd")
    _check_generalize_workload(25, 1, 2, 12.6)
    assert "25 pair(s) x 1 controller(s) x 2 payload(s) = 50 runs" in caplog.text
    assert "~630 s of robot time, about 3 min on 1 quiet core(s)" in caplog.text
    caplog.clear()
    _check_generalize_workload(10_000, 1, 2, 7.5, workers=2)  # the largest grid: accepted
    assert "~1.5e+05 s of robot time, about 7.7 h on 2 quiet core(s)" in caplog.text
    with pytest.raises(InvalidInput, match=r"--pairs 10000 x --controllers 5 .*fewer --pairs"):
        _check_generalize_workload(10_000, 5, 20, 12.6)


def test_generalize_payloads_are_few_and_different(tmp_path: Path, capsys) -> None:
    model = tmp_path / "m.npz"
    model.write_bytes(b"refused before it is read")
    many = ",".join(f"{0.01 * i:g}" for i in range(200))
    for payloads in (many, "0,1.2,1.2"):
        argv = ["experiment", "generalize", str(model), "--payloads", payloads]
        assert main([*argv, "-o", str(tmp_path / "gen")]) == 1
        assert "--payloads" in capsys.readouterr().err


def test_a_payload_study_whose_every_run_stopped_fails(tmp_path: Path, capsys) -> None:
    """A 1 s lift over the box is too fast for PD: every run hits a safety stop."""
    argv = ["experiment", "payload", "--controllers", "pd", "--duration-s", "1"]
    assert main([*argv, "--workers", "1", "-o", str(tmp_path / "ex"), "-q"]) == 1
    captured = capsys.readouterr()
    assert "STOPPED" in captured.out  # the table still shows what happened
    line = captured.err.strip().splitlines()[-1]
    assert line.startswith("dexlfd experiment: error: every one of the ")
    assert "no error over the obstacle was measured" in line and "--duration-s" in line
    assert (tmp_path / "ex" / "payload_lift_z.png").exists()  # it shows where they stopped


def test_inf_in_one_keypoint_is_refused_not_exported(tmp_path: Path, capsys) -> None:
    import numpy as np

    from dexlfd.datasets import pick_place_demonstrations
    from dexlfd.io import save_demonstration

    demo = pick_place_demonstrations(1, np.random.default_rng(2))[0]
    good = save_demonstration(tmp_path / "d.npz", demo)
    with np.load(good, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["keypoints"][5, 3, 1] = np.inf
    bad = tmp_path / "bad.npz"
    np.savez_compressed(bad, **arrays)
    assert main(["export", str(bad), "-o", str(tmp_path / "out.csv")]) == 1
    err = capsys.readouterr().err
    assert "bad.npz" in err and "'keypoints' contains inf (at sample 5)" in err
    assert not (tmp_path / "out.csv").exists()
