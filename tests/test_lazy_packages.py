"""``dexlfd.learn`` and ``dexlfd.plan`` import their names on first use, and every name holds."""

from __future__ import annotations

import importlib
import subprocess
import sys
import types

import pytest

PACKAGES = ("dexlfd.learn", "dexlfd.plan")


def _modules_after(code: str) -> set[str]:
    """Names in ``sys.modules`` after ``code`` runs in a fresh interpreter."""
    script = f"{code}\nimport sys\nprint('\\n'.join(sys.modules))"
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, timeout=300
    )
    return set(out.stdout.split())


def test_teach_settings_load_neither_numba_nor_scipy() -> None:
    """teach's settings (LearnConfig's default among them) come without the learning code."""
    loaded = _modules_after(
        "from dexlfd.apps.teach import TeachConfig\nfrom dexlfd.plan import PlanConfig\n"
        "TeachConfig(sources=('a.mp4',))"
    )
    assert "numba" not in loaded
    assert "scipy" not in loaded
    assert "dexlfd.learn.dtw" not in loaded


@pytest.mark.parametrize("package", PACKAGES)
def test_every_exported_name_resolves_to_its_source(package: str) -> None:
    pkg = importlib.import_module(package)
    exports = pkg._lazy_exports
    assert set(pkg.__all__) == set(exports)
    for name, source in exports.items():
        assert getattr(pkg, name) is getattr(importlib.import_module(source), name)
    assert set(exports) <= set(dir(pkg))
    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        _ = pkg.not_a_name


def test_a_function_named_like_its_submodule_stays_the_function() -> None:
    """``import dexlfd.learn.dtw`` does not turn ``dexlfd.learn.dtw`` into the module."""
    import dexlfd.learn
    import dexlfd.learn.dtw
    import dexlfd.plan
    import dexlfd.plan.forcing

    assert isinstance(dexlfd.learn.dtw, types.FunctionType)
    assert isinstance(dexlfd.plan.forcing, types.FunctionType)
    assert isinstance(sys.modules["dexlfd.learn.dtw"], types.ModuleType)
    # a name that is no export is an ordinary attribute: a submodule stays the module
    import dexlfd.learn.events

    assert isinstance(dexlfd.learn.events, types.ModuleType)
