"""The input sweep (benchmarks/sweep_inputs.py) still builds its cases and classifies runs.

The sweep itself is slow and is not part of the test suite; this runs five cheap cases of
it and checks its classification on made-up outcomes.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "sweep_inputs.py"


@pytest.fixture(scope="module")
def sweep() -> ModuleType:
    spec = importlib.util.spec_from_file_location("sweep_inputs", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["sweep_inputs"] = module
    spec.loader.exec_module(module)
    return module


def test_five_cheap_cases_run_and_are_classified(sweep: ModuleType, tmp_path: Path) -> None:
    """In its own interpreter, as a user runs it: the sweep forks a child per case, and a
    fork of this test process (its threads, its imports) is not what it measures."""
    import subprocess

    pattern = r"^synth/flag/-n=(nan|word|fraction|below-lo|above-hi)$"
    run = subprocess.run(
        [sys.executable, str(SCRIPT), "--filter", pattern, "-o", str(tmp_path / "out")],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    report = json.loads((tmp_path / "out" / "sweep.json").read_text())
    cases = report["cases"]
    assert sorted(c["id"] for c in cases) == sorted(
        f"synth/flag/-n={v}" for v in ("nan", "word", "fraction", "below-lo", "above-hi")
    )
    for case in cases:
        assert case["class"] in sweep.CLASSES
        assert case["argv"][0].startswith("dexlfd synth ")
        assert case["expect"] == "error"
        # argparse refuses each of these values in one line naming the flag
        assert case["class"] == "clean", case
        assert "-n" in case["error_line"], case
    table = (tmp_path / "out" / "table.txt").read_text()
    assert "synth" in table and "clean" in table


def test_every_case_id_is_unique_and_every_subcommand_is_swept(sweep: ModuleType) -> None:
    cases = [
        *sweep.flag_cases(), *sweep.unit_and_value_cases(), *sweep.wrong_kind_cases(),
        *sweep.source_cases(), *sweep.output_cases(), *sweep.chain_cases(),
        *sweep.misc_cases(), *sweep.sigint_cases(),
    ]  # fmt: skip
    ids = [c.cid for c in cases]
    assert len(ids) == len(set(ids))
    assert len(ids) >= 600
    commands = {c.command for c in cases}
    for name in ("calibrate", "record", "synth", "learn", "plan", "simulate", "experiment",
                 "export", "teleop", "demo"):  # fmt: skip
        assert name in commands
    assert {c.expect for c in cases} <= {"ok", "error", "complain", "any"}


def _result(sweep: ModuleType, rc: int | None, stderr: str = "") -> object:
    return sweep.StepResult(rc, None, stderr, 0.1, 10.0)


def test_classification_of_made_up_outcomes(sweep: ModuleType, tmp_path: Path) -> None:
    cdir, tmp = tmp_path / "case", tmp_path / "tmp"
    cdir.mkdir()
    tmp.mkdir()
    (cdir / "in.npz").write_bytes(b"input")
    before = sweep._snapshot(cdir)

    def cls(case: object, result: object) -> str:
        return sweep.classify(case, [result], cdir, tmp, before, all_steps=True).cls

    refuse = sweep.Case("x/y", [["plan", "in.npz"]], "error", "why", needles=("in.npz",))
    line = "dexlfd plan: error: in.npz: not a model\n"
    assert cls(refuse, _result(sweep, 1, line)) == "clean"
    assert cls(refuse, _result(sweep, 0)) == "silent"
    assert cls(refuse, _result(sweep, None)) == "hang"
    assert cls(refuse, _result(sweep, 1, "dexlfd plan: error: no\n")) == "unclear"
    assert cls(refuse, _result(sweep, 1, "Traceback (most recent call last):\nKeyError: 1\n")) == (
        "traceback"
    )
    assert cls(refuse, _result(sweep, 1, "numpy: Unable to allocate 7 TiB\n")) == (
        "unbounded memory"
    )
    complain = sweep.Case("x/z", [["learn"]], "complain", "why", outputs=("m.npz",))
    (cdir / "m.npz").write_bytes(b"model")
    assert cls(complain, _result(sweep, 0, "W dexlfd.io: steps of 1 s: frame numbers?\n")) == (
        "clean"
    )
    assert cls(complain, _result(sweep, 0)) == "silent"
    (cdir / ".m.npz.abc.dexlfd-part").write_bytes(b"half")
    assert cls(complain, _result(sweep, 0, "W dexlfd: x\n")) == "leftover"
    (cdir / "in.npz").write_bytes(b"replaced")
    assert cls(complain, _result(sweep, 0, "W dexlfd: x\n")) == "lost file"
