"""Dependencies point one way: capture -> motion -> learn -> plan -> control (robot by control)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "dexlfd"
STAGES = ("capture", "motion", "learn", "plan", "control")
# leaf modules every stage may import: they import no stage (NumPy only)
LEAVES = ("panda", "panda_kinematics", "panda_ik", "geometry", "rotations", "trajectory")


def _imports(path: Path) -> set[str]:
    """The dexlfd subpackages/modules ``path`` imports (absolute imports, any depth)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        out |= {n.split(".")[1] for n in names if n.startswith("dexlfd.")}
    return out


@pytest.mark.parametrize("stage", STAGES)
def test_a_stage_imports_no_later_stage_and_only_control_imports_robot(stage: str) -> None:
    later = set(STAGES[STAGES.index(stage) + 1 :])
    forbidden = later | ({"robot"} if stage != "control" else set())
    bad = {
        str(f.relative_to(SRC)): sorted(_imports(f) & forbidden)
        for f in (SRC / stage).rglob("*.py")
        if _imports(f) & forbidden
    }
    assert not bad, f"{stage}/ imports {bad}"


@pytest.mark.parametrize("leaf", LEAVES)
def test_a_leaf_module_imports_no_stage(leaf: str) -> None:
    used = _imports(SRC / f"{leaf}.py")
    assert not used & {*STAGES, "robot", "io", "viz", "experiments", "apps"}, used


def test_robot_imports_no_stage() -> None:
    bad = {
        str(f.relative_to(SRC)): sorted(_imports(f) & set(STAGES))
        for f in (SRC / "robot").rglob("*.py")
        if _imports(f) & set(STAGES)
    }
    assert not bad, bad


def test_the_checker_sees_an_import(tmp_path: Path) -> None:
    f = tmp_path / "m.py"
    f.write_text("def f():\n    from dexlfd.robot.ik import solve_ik\n")
    assert _imports(f) == {"robot"}
