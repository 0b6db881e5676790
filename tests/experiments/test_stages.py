from __future__ import annotations

from pathlib import Path

import pytest

from dexlfd.experiments._stages import Stage, StageRunner, settings_key


def _stages(calls: list[str], key_b: str = "b", fail_b: bool = False) -> list[Stage]:
    def make(name: str, fail: bool = False):
        def run(out: Path):
            calls.append(name)
            if fail:
                raise KeyboardInterrupt
            path = out / f"{name}.txt"
            path.write_text(name)
            return {"file": path}, {"n": 1}

        return run

    return [
        Stage("a", "A", "a", make("a")),
        Stage("b", "B", key_b, make("b", fail_b)),
        Stage("c", "C", "c", make("c")),
    ]


def test_resume_after_interrupt_and_rerun_on_changed_settings(tmp_path: Path) -> None:
    calls: list[str] = []
    with pytest.raises(KeyboardInterrupt):
        StageRunner(tmp_path).run(_stages(calls, fail_b=True))
    assert calls == ["a", "b"]
    calls.clear()
    StageRunner(tmp_path).run(_stages(calls))
    assert calls == ["b", "c"]  # a reused
    calls.clear()
    res = StageRunner(tmp_path).run(_stages(calls))
    assert calls == [] and res["c"]["reused"]
    StageRunner(tmp_path).run(_stages(calls, key_b="b2"))
    assert calls == ["b", "c"]  # b changed: b and everything after rerun
    calls.clear()
    (tmp_path / "a.txt").unlink()
    StageRunner(tmp_path).run(_stages(calls))
    assert calls == ["a", "b", "c"]
    calls.clear()
    StageRunner(tmp_path, fresh=True).run(_stages(calls))
    assert calls == ["a", "b", "c"]


def test_corrupt_manifest_starts_clean(tmp_path: Path) -> None:
    (tmp_path / "manifest.json").write_text("{not json")
    calls: list[str] = []
    StageRunner(tmp_path).run(_stages(calls))
    assert calls == ["a", "b", "c"]
    assert settings_key(1, "x") == settings_key(1, "x") != settings_key(2, "x")
