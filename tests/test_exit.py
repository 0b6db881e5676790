"""The ``dexlfd`` process's exit: fast when nothing is left to finish, never losing output."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from dexlfd._exit import files_open_for_writing

pytestmark = pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc (Linux)")


def _run(body: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    script = "import atexit, sys, threading, time\nfrom dexlfd._exit import exit_process\n" + body
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    env.pop("DEXLFD_NO_FAST_EXIT", None)
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          cwd=tmp_path, env=env, check=False, timeout=120)  # fmt: skip


def test_the_exit_keeps_the_code_the_output_and_runs_the_atexit_handlers(tmp_path) -> None:
    proc = _run(
        "atexit.register(lambda: open('handler.txt', 'w').write('ran'))\n"
        "sys.stdout.write('x' * 100_000)\n"  # buffered in the pipe's stream, not yet written
        "sys.stderr.write('last words')\n"
        "exit_process(3)\n",
        tmp_path,
    )
    assert proc.returncode == 3
    assert proc.stdout == "x" * 100_000 and proc.stderr == "last words"
    assert (tmp_path / "handler.txt").read_text() == "ran"


def test_a_file_left_open_for_writing_keeps_its_bytes(tmp_path) -> None:
    proc = _run("kept = open('open.txt', 'w')\nkept.write('buffered')\nexit_process(0)\n", tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "open.txt").read_text() == "buffered"


def test_a_thread_still_working_is_waited_for(tmp_path) -> None:
    proc = _run(
        "def work():\n"
        "    time.sleep(0.5)\n"
        "    open('thread.txt', 'w').write('done')\n"
        "threading.Thread(target=work).start()\n"
        "exit_process(0)\n",
        tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "thread.txt").read_text() == "done"


def test_files_open_for_writing_are_listed_and_files_read_are_not(tmp_path) -> None:
    read, written = tmp_path / "read.txt", tmp_path / "written.txt"
    read.write_text("r")
    with open(read) as _, open(written, "w"):
        listed = files_open_for_writing()
    assert listed is not None
    assert str(written) in listed and str(read) not in listed
    assert str(written) not in (files_open_for_writing() or [])


def test_shared_memory_does_not_keep_the_teardown(tmp_path) -> None:
    """multiprocessing's values live in an unlinked file open for writing: not a reason to wait.

    The teardown is seen by what it runs: an object's ``__del__`` at the interpreter's end.
    """
    witness = (
        "import os\n"
        "class Witness:\n"
        "    def __del__(self, os=os):\n"  # os bound now: modules are emptied at the end
        "        fd = os.open('teardown.txt', os.O_WRONLY | os.O_CREAT, 0o644)\n"
        "        os.write(fd, b'ran')\n"
        "        os.close(fd)\n"
        "witness = Witness()\n"
    )
    # left by the normal exit, the witness sees the teardown
    proc = _run(witness + "sys.exit(0)\n", tmp_path)
    assert (tmp_path / "teardown.txt").read_bytes() == b"ran", proc.stderr
    (tmp_path / "teardown.txt").unlink()
    proc = _run(
        witness + "import multiprocessing\n"
        "count = multiprocessing.get_context('fork').RawValue('q', 0)\n"
        "exit_process(0)\n",
        tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert not (tmp_path / "teardown.txt").exists()


def test_an_unlinked_file_is_not_listed(tmp_path) -> None:
    path = tmp_path / "gone.bin"
    with open(path, "wb") as fh:
        os.unlink(path)
        fh.write(b"x")
        assert str(path) not in " ".join(files_open_for_writing() or [])
