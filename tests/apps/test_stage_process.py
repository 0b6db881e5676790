"""A stage run in a forked child: its error is the same error here (or one line naming
the stage when it died), its log lines come before its ``done``, and it ends when the
run's process dies.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from dexlfd.apps._stages import Stage, StageRunner
from dexlfd.errors import DependencyNotInstalled, DexlfdError, InvalidInput


def _logs(out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    for k in range(50):
        logging.getLogger("dexlfd.apps.test").info("line %d of the child", k)
    return {}, {}


def test_a_forked_stages_log_lines_come_before_its_done(tmp_path: Path, caplog) -> None:
    with caplog.at_level(logging.INFO, logger="dexlfd"):
        StageRunner(tmp_path).run([Stage("a", "A", "a", _logs, background=True)])
    said = [r.getMessage() for r in caplog.records]
    lines = [m for m in said if m.startswith(("line ", "A done"))]
    assert lines == [*(f"line {k} of the child" for k in range(50)), lines[-1]]
    assert lines[-1].startswith("A done in")


def _priority(out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    return {}, {"nice": os.nice(0), "pid": os.getpid()}


def test_a_background_stage_yields_the_cores_by_its_nice(tmp_path: Path) -> None:
    here = os.nice(0)
    res = StageRunner(tmp_path).run([
        Stage("low", "L", "l", _priority, background=True, nice=7),
        Stage("same", "S", "s", _priority, background=True),
        Stage("fg", "F", "f", _priority),
    ])  # fmt: skip
    got = {name: r["summary"] for name, r in res.items()}
    assert got["low"]["pid"] != os.getpid() and got["fg"]["pid"] == os.getpid()
    assert got["low"]["nice"] == min(here + 7, 19)
    assert got["same"]["nice"] == here == got["fg"]["nice"] == os.nice(0)  # this one unchanged


def _raises(exc: BaseException) -> Any:
    def run(out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
        raise exc

    return run


def test_an_error_in_a_forked_stage_is_the_same_error_here(tmp_path: Path) -> None:
    bad = InvalidInput("pick out of reach", param="pick")
    with pytest.raises(InvalidInput, match="pick out of reach") as got:
        StageRunner(tmp_path).run([Stage("a", "A", "a", _raises(bad), background=True)])
    assert got.value.param == "pick"
    assert "in the stage's process" in "".join(got.value.__notes__)  # its traceback there
    # an error that cannot be rebuilt from its message: the same text, one line
    missing = DependencyNotInstalled("mediapipe", "tracking a video", extra="capture")
    with pytest.raises(DexlfdError) as got:
        StageRunner(tmp_path).run([Stage("a", "A", "a", _raises(missing), background=True)])
    assert str(got.value) == str(missing)


def _killed(out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    os.kill(os.getpid(), signal.SIGKILL)
    raise AssertionError("unreachable")


def test_a_stage_whose_child_is_killed_is_said_in_one_line(tmp_path: Path) -> None:
    stage = Stage("record", "R", "r", _killed, background=True)
    with pytest.raises(DexlfdError, match=r"^stage record: its process died \(exit code -9\)$"):
        StageRunner(tmp_path).run([stage])


_ORPHAN = """
import os, sys, time
from pathlib import Path
from dexlfd.apps._stages import Stage, StageRunner

def track(out):
    (out / "child.pid").write_text(str(os.getpid()))
    time.sleep(60)
    return {}, {}

StageRunner(Path(sys.argv[1])).run([Stage("a", "A", "a", track, background=True),
                                    Stage("b", "B", "b", lambda out: time.sleep(60))])
"""


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux: prctl")
def test_a_forked_stage_ends_when_the_run_is_killed(tmp_path: Path) -> None:
    """SIGKILL runs no cleanup in the run: the child still does not go on alone."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    run = subprocess.Popen([sys.executable, "-c", _ORPHAN, str(tmp_path)], env=env)
    try:
        for _ in range(3000):
            if (tmp_path / "child.pid").is_file() and (tmp_path / "child.pid").read_text():
                break
            time.sleep(0.01)
        child = int((tmp_path / "child.pid").read_text())
        assert _alive(child)
    finally:
        run.kill()
        run.wait()
    for _ in range(500):
        if not _alive(child):
            break
        time.sleep(0.01)
    orphan = _alive(child)
    if orphan:
        os.kill(child, signal.SIGKILL)
    assert not orphan
