"""native_stderr_silenced: native fd-2 lines hidden, ours shown, a native crash still explained."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

SCRIPT = """
import faulthandler, logging, os, sys
from dexlfd._stderr import native_stderr_silenced
log = logging.getLogger("dexlfd")
log.addHandler(logging.StreamHandler(sys.stderr))
with native_stderr_silenced():
    os.write(2, b"NATIVE-NOISE\\n")
    with native_stderr_silenced():  # nested: the outer redirection stays
        os.write(2, b"NATIVE-NESTED\\n")
        log.warning("OUR-WARNING")
    print("OUR-LINE", file=sys.stderr)
os.write(2, b"AFTER\\n")
if sys.argv[1] == "crash":
    with native_stderr_silenced():
        faulthandler._sigsegv()
"""


def _run(mode: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    env.pop("DEXLFD_MEDIAPIPE_LOGS", None)
    return subprocess.run(
        [sys.executable, "-c", SCRIPT, mode], env=env, capture_output=True, text=True, timeout=60
    )


def test_native_lines_are_hidden_and_ours_shown_and_fd2_restored() -> None:
    done = _run("ok")
    assert done.returncode == 0, done.stderr
    assert "NATIVE" not in done.stderr
    assert "OUR-WARNING" in done.stderr and "OUR-LINE" in done.stderr
    assert "AFTER" in done.stderr  # fd 2 is the terminal's again


def test_a_native_crash_inside_still_prints_its_reason() -> None:
    done = _run("crash")
    assert done.returncode != 0
    assert "Segmentation fault" in done.stderr and "Fatal Python error" in done.stderr
