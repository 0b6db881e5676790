from __future__ import annotations

from pathlib import Path

import pytest

from dexlfd.cli import main
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
    argv = ["plan", str(model), "-o", str(plan), "--duration-s", "3000", "--rate-hz", "2000"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "samples" in err and "--rate-hz 2000" in err and not plan.exists()
