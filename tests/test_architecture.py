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


# ---------------------------------------------------------------- size and names

MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 100


def _modules() -> list[Path]:
    return sorted(SRC.rglob("*.py"))


def _long_functions(path: Path, limit: int) -> list[str]:
    """``name (lines)`` of every function or method in ``path`` longer than ``limit`` lines."""
    return [
        f"{node.name} ({node.end_lineno - node.lineno + 1})"
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        and node.end_lineno is not None
        and node.end_lineno - node.lineno + 1 > limit
    ]


def _re_exports(path: Path) -> list[str]:
    """Names in ``path``'s ``__all__`` that it imports rather than defines."""
    tree = ast.parse(path.read_text())
    imported: set[str] = set()
    exported: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            imported |= {(a.asname or a.name).split(".")[0] for a in node.names}
    for node in tree.body:
        if isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                value = node.value
                if isinstance(value, ast.List | ast.Tuple):
                    exported += [e.value for e in value.elts if isinstance(e, ast.Constant)]
    return sorted(set(exported) & imported)


def test_no_module_is_longer_than_500_lines() -> None:
    long = {
        str(f.relative_to(SRC)): n
        for f in _modules()
        if (n := len(f.read_text().splitlines())) > MAX_MODULE_LINES
    }
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"


def test_no_function_is_longer_than_100_lines() -> None:
    long = {
        str(f.relative_to(SRC)): names
        for f in _modules()
        if (names := _long_functions(f, MAX_FUNCTION_LINES))
    }
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines: {long}"


def test_names_are_re_exported_only_by_a_package_init() -> None:
    found = {
        str(f.relative_to(SRC)): names
        for f in _modules()
        if f.name != "__init__.py" and (names := _re_exports(f))
    }
    assert not found, f"import these from the module that defines them: {found}"


def test_the_size_and_re_export_checkers_see_them(tmp_path: Path) -> None:
    f = tmp_path / "m.py"
    body = "\n".join(f"    x{i} = {i}" for i in range(100))
    f.write_text(
        "from dexlfd.trajectory import resample\n\n"
        '__all__ = ["g", "resample"]\n\n\n'
        f"def g():\n{body}\n    return x0\n"
    )
    assert _long_functions(f, MAX_FUNCTION_LINES) == ["g (102)"]
    assert _long_functions(f, 102) == []
    assert _re_exports(f) == ["resample"]
