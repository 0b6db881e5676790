from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest

from dexlfd.apps._stages import Stage, StageRunner, settings_key


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


def _plan_stage(calls: list[str], check=None) -> list[Stage]:
    import numpy as np

    from dexlfd.io import Plan, save_plan

    def run(out: Path):
        calls.append("plan")
        n, z = 20, np.zeros((20, 3))
        plan = Plan(t=np.arange(n) * 0.01, position=z + 0.3, velocity=z, acceleration=z,
                    quaternion=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)), angular_velocity=z,
                    gripper=np.full(n, 0.04))  # fmt: skip
        return {"plan": save_plan(out / "plan.npz", plan)}, {}

    def after(out: Path):
        calls.append("after")
        return {}, {}

    extra = {} if check is None else {"check": check}
    return [Stage("plan", "P", "k", run, **extra), Stage("after", "A", "k", after)]


def test_truncated_output_is_not_reused(tmp_path: Path, caplog) -> None:
    calls: list[str] = []
    StageRunner(tmp_path).run(_plan_stage(calls))
    path = tmp_path / "plan.npz"
    path.write_bytes(path.read_bytes()[:100])  # a crash or a copy cut it short
    calls.clear()
    with caplog.at_level("WARNING"):
        StageRunner(tmp_path).run(_plan_stage(calls))
    assert calls == ["plan", "after"]  # reran, and so did what depends on it
    assert "plan.npz changed since it was written" in caplog.text
    calls.clear()
    StageRunner(tmp_path).run(_plan_stage(calls))
    assert calls == []  # the rewritten file is reused


def test_an_output_that_does_not_validate_is_not_reused(tmp_path: Path, caplog) -> None:
    from dexlfd.errors import InvalidFile

    calls: list[str] = []
    StageRunner(tmp_path).run(_plan_stage(calls))

    def refuse(outputs):
        raise InvalidFile(f"{outputs['plan']}: refused by the check")

    calls.clear()
    with caplog.at_level("WARNING"):
        StageRunner(tmp_path).run(_plan_stage(calls, check=refuse))
    assert calls == ["plan", "after"] and "refused by the check" in caplog.text


def test_default_check_loads_npz_outputs(tmp_path: Path) -> None:
    from dexlfd.apps._stages import check_npz_outputs
    from dexlfd.errors import InvalidFile

    calls: list[str] = []
    StageRunner(tmp_path).run(_plan_stage(calls))
    check_npz_outputs({"plan": tmp_path / "plan.npz"})  # loads
    (tmp_path / "x.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(InvalidFile, match="x.npz"):
        check_npz_outputs({"x": tmp_path / "x.npz"})


def test_manifest_without_hashes_reruns(tmp_path: Path, caplog) -> None:
    import json

    calls: list[str] = []
    StageRunner(tmp_path).run(_stages(calls))
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    for entry in manifest.values():
        entry.pop("hashes")
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    calls.clear()
    with caplog.at_level("WARNING"):
        StageRunner(tmp_path).run(_stages(calls))
    assert calls == ["a", "b", "c"] and "no content hashes recorded" in caplog.text


def test_content_hash_of_a_folder_sees_names_and_bytes(tmp_path: Path) -> None:
    from dexlfd.apps._stages import content_hash

    (tmp_path / "bag").mkdir()
    (tmp_path / "bag" / "a").write_bytes(b"1")
    h = content_hash(tmp_path / "bag")
    (tmp_path / "bag" / "a").rename(tmp_path / "bag" / "b")
    assert content_hash(tmp_path / "bag") != h
    (tmp_path / "bag" / "b").rename(tmp_path / "bag" / "a")
    assert content_hash(tmp_path / "bag") == h


def _bg_stages(tmp: Path, fail: bool = False) -> list[Stage]:
    """b runs in a child process; c does not need it, d reads its output."""

    def write(name: str, reads: str | None = None):
        def run(out: Path):
            if fail and name == "b":
                raise ValueError("b broke")
            text = name + ("" if reads is None else "+" + (out / f"{reads}.txt").read_text())
            path = out / f"{name}.txt"
            path.write_text(text)
            with (out / "log.txt").open("a") as fh:
                fh.write(name + "\n")
            return {"file": path}, {"pid": __import__("os").getpid()}

        return run

    return [
        Stage("a", "A", "a", write("a")),
        Stage("b", "B", "b", write("b", reads="a"), after=("a",), background=True),
        Stage("c", "C", "c", write("c", reads="a"), after=("a",)),
        Stage("d", "D", "d", write("d", reads="b"), after=("b", "c")),
    ]


def test_background_stage_runs_in_a_child_and_is_waited_for(tmp_path: Path) -> None:
    import os

    res = StageRunner(tmp_path).run(_bg_stages(tmp_path))
    assert list(res) == ["a", "b", "c", "d"]
    assert res["b"]["summary"]["pid"] != os.getpid() == res["c"]["summary"]["pid"]
    assert (tmp_path / "d.txt").read_text() == "d+b+a"  # d saw b's finished output
    again = StageRunner(tmp_path).run(_bg_stages(tmp_path))
    assert all(r["reused"] for r in again.values())
    (tmp_path / "b.txt").unlink()  # b reruns; so does d (reads b), not c
    (tmp_path / "log.txt").unlink()
    StageRunner(tmp_path).run(_bg_stages(tmp_path))
    assert sorted((tmp_path / "log.txt").read_text().split()) == ["b", "d"]


def _pid(out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    import os

    return {}, {"pid": os.getpid()}


def test_a_stage_that_renders_stays_here_once_this_process_has_an_opengl_context(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog
) -> None:
    """A fork of a process with an OpenGL context cannot draw; other stages still fork."""
    import os

    from dexlfd.apps import _stages

    def stages() -> list[Stage]:
        return [Stage("v", "V", "v", _pid, background=True, renders=True),
                Stage("f", "F", "f", _pid, after=(), background=True)]  # fmt: skip

    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    # as in a process that never drew (an earlier test in this worker may have drawn)
    monkeypatch.setattr(_stages, "context_made", lambda: False)
    res = StageRunner(tmp_path / "a").run(stages())
    assert res["v"]["summary"]["pid"] != os.getpid() != res["f"]["summary"]["pid"]
    monkeypatch.setattr(_stages, "context_made", lambda: True)
    with caplog.at_level(logging.INFO, logger="dexlfd"):
        res = StageRunner(tmp_path / "b").run(stages())
    assert res["v"]["summary"]["pid"] == os.getpid() != res["f"]["summary"]["pid"]
    assert any("OpenGL context" in r.getMessage() for r in caplog.records)


def test_a_background_stage_stays_here_when_it_says_why(tmp_path: Path, caplog) -> None:
    """``here`` is asked as the stage starts: what an earlier stage left decides."""
    import os

    left: dict[str, str] = {}

    def started(out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
        left["video"] = "in this process"
        return {}, {}

    def stages() -> list[Stage]:
        why = lambda: "collects what s started" if left else None  # noqa: E731
        return [Stage("s", "S", "s", started),
                Stage("v", "V", "v", _pid, background=True, here=why)]  # fmt: skip

    with caplog.at_level(logging.INFO, logger="dexlfd"):
        res = StageRunner(tmp_path).run(stages())
    assert res["v"]["summary"]["pid"] == os.getpid()
    assert any("V ... (here: collects what s started)" in r.getMessage() for r in caplog.records)
    left.clear()
    (tmp_path / "manifest.json").unlink()
    stages_ = stages()
    stages_[0] = Stage("s", "S", "s", lambda out: ({}, {}))  # leaves nothing this time
    res = StageRunner(tmp_path).run(stages_)
    assert res["v"]["summary"]["pid"] != os.getpid()


def _logs_from_the_child(out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    import logging
    import os

    logging.getLogger("dexlfd.apps.test").warning("said in process %d", os.getpid())
    return {}, {}


def test_a_background_stages_log_lines_are_written_by_the_parent(tmp_path: Path, caplog) -> None:
    """Its records reach this process's handlers (which keep them above a progress bar)."""
    import os

    with caplog.at_level(logging.INFO, logger="dexlfd"):
        StageRunner(tmp_path).run([Stage("a", "A", "a", _logs_from_the_child, background=True)])
    said = [r for r in caplog.records if r.getMessage().startswith("said in process")]
    assert len(said) == 1 and said[0].name == "dexlfd.apps.test"
    assert said[0].getMessage() != f"said in process {os.getpid()}"  # from the child


def test_background_stage_failure_is_raised(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="b broke"):
        StageRunner(tmp_path).run(_bg_stages(tmp_path, fail=True))
    assert not (tmp_path / "d.txt").exists()
    manifest = __import__("json").loads((tmp_path / "manifest.json").read_text())
    assert "b" not in manifest and "a" in manifest


def test_a_killed_background_stage_leaves_no_stray_after_the_resume(tmp_path: Path) -> None:
    """A stage killed mid-write leaves its temporary; the next run removes it, and only it."""
    import os
    import signal

    from dexlfd.io._atomic import temp_file

    sub = tmp_path / "capture"
    sub.mkdir()
    keep = sub / ".hidden-user-file"  # a dot file that is not ours stays
    keep.write_text("mine")

    def killed(out: Path):
        temp_file(out / "capture" / "overlay.mp4", ".mp4")  # a writer's temporary
        os.kill(os.getpid(), signal.SIGKILL)  # no cleanup runs
        raise AssertionError("unreachable")

    with pytest.raises(Exception, match="died"):
        StageRunner(tmp_path).run([Stage("a", "A", "a", killed, background=True)])
    strays = list(sub.glob(".overlay.mp4.*"))
    assert len(strays) == 1
    calls: list[str] = []
    StageRunner(tmp_path).run(_stages(calls))
    assert not list(sub.glob(".overlay.mp4.*"))
    assert keep.read_text() == "mine"


def test_ctrl_c_stops_a_background_stage_and_removes_its_temporary(tmp_path: Path) -> None:
    """The interrupted run itself cleans up after the child it terminated (not only a resume)."""
    import time

    from dexlfd.io._atomic import temp_file

    started = tmp_path / "started"

    def writing(out: Path):
        temp_file(out / "robot.mp4", ".mp4")  # a writer's temporary, mid-write
        started.write_text("1")
        time.sleep(600)  # terminated by the parent long before this ends

    def interrupted(out: Path):
        for _ in range(6000):  # wait until the child is mid-write
            if started.exists():
                break
            time.sleep(0.01)
        raise KeyboardInterrupt

    stages = [
        Stage("v", "V", "v", writing, background=True),
        Stage("x", "X", "x", interrupted, after=()),
    ]
    with pytest.raises(KeyboardInterrupt):
        StageRunner(tmp_path).run(stages)
    assert started.exists()
    assert not list(tmp_path.glob(".robot.mp4.*"))


def test_an_installed_extra_or_a_new_version_reruns_the_stages(tmp_path: Path, caplog) -> None:
    """The environment (dexlfd's version, the extras) is part of what a stage is reused for."""
    from dexlfd.apps._stages import environment

    env = environment()
    assert env["dexlfd"] and "imageio-ffmpeg" in env and "rosbags" in env
    calls: list[str] = []
    StageRunner(tmp_path, env=env).run(_stages(calls))
    calls.clear()
    StageRunner(tmp_path, env=dict(env)).run(_stages(calls))
    assert calls == []  # same environment: every stage reused
    with caplog.at_level("INFO"):
        StageRunner(tmp_path, env={**env, "imageio-ffmpeg": "9.9"}).run(_stages(calls))
    assert calls == ["a", "b", "c"]
    assert "installed extras, the dexlfd version or its source changed" in caplog.text
    calls.clear()
    StageRunner(tmp_path, env={**env, "dexlfd": "0.0.1"}).run(_stages(calls))
    assert calls == ["a", "b", "c"]


def test_a_changed_source_file_reruns_the_stages(tmp_path: Path, caplog) -> None:
    """The same version with an edited source file does not reuse the finished stages."""
    from dexlfd.apps._stages import environment, source_hash

    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("X = 1\n")
    (pkg / "sub" / "b.py").write_text("Y = 2\n")
    (pkg / "notes.txt").write_text("not code")
    out = tmp_path / "out"
    out.mkdir()
    env = environment(pkg)
    assert env["dexlfd_source"] == source_hash(pkg)
    assert environment()["dexlfd_source"] != env["dexlfd_source"]  # dexlfd's own sources
    calls: list[str] = []
    StageRunner(out, env=env).run(_stages(calls))
    calls.clear()
    (pkg / "notes.txt").write_text("edited, but no source")
    source_hash.cache_clear()
    StageRunner(out, env=environment(pkg)).run(_stages(calls))
    assert calls == []  # the sources are the same: every stage reused
    (pkg / "sub" / "b.py").write_text("Y = 3\n")  # same version number, edited code
    source_hash.cache_clear()
    with caplog.at_level("INFO"):
        StageRunner(out, env=environment(pkg)).run(_stages(calls))
    assert calls == ["a", "b", "c"]
    assert "its source changed" in caplog.text


def _spin(out: Path) -> tuple[dict[str, Path], dict[str, object]]:
    """A stage that does CPU work (a fixed amount of arithmetic) and writes one file."""
    total = 0
    for i in range(2_000_000):
        total += i * i
    path = out / "spin.txt"
    path.write_text(str(total))
    return {"file": path}, {}


@pytest.mark.parametrize("background", [False, True])
def test_each_stage_records_its_cpu_time_in_results_and_manifest(
    tmp_path: Path, background: bool
) -> None:
    import json

    stages = [Stage("spin", "spin", "k", _spin, background=background)]
    res = StageRunner(tmp_path).run(stages)
    cpu = res["spin"]["cpu_seconds"]
    assert cpu > 0.0
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["spin"]["cpu_seconds"] == cpu
    again = StageRunner(tmp_path).run(stages)  # reused: the recorded figure, not zero
    assert again["spin"]["reused"] and again["spin"]["cpu_seconds"] == cpu
