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
