"""Every example script runs (MPLBACKEND=Agg, synthetic data, no camera).

Each script gets an explicit ``--out`` folder under pytest's temporary folder, so a
run writes nothing into the repository (pytest's own ``sys.argv`` must never be read
as an output folder).
"""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.py"))


@pytest.mark.integration
@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs(
    script: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    out = tmp_path / "out"
    monkeypatch.setattr(sys, "argv", [str(script), "--out", str(out)])
    runpy.run_path(str(script), run_name="__main__")
    assert capsys.readouterr().out  # examples say what they did
    figures = sorted(out.rglob("*.png"))
    assert figures and all(f.stat().st_size > 0 for f in figures)  # and wrote their figures there
