"""Atomic folder writes: the folder appears complete under its name, or not at all."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from dexlfd.errors import InvalidFile
from dexlfd.io._atomic import atomic_folder


def test_folder_appears_only_when_the_block_succeeds(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    with atomic_folder(out) as tmp:
        tmp.mkdir()
        (tmp / "a.txt").write_text("x")
        assert not out.exists()  # nothing under the final name while writing
    assert (out / "a.txt").read_text() == "x"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]


def test_failure_leaves_nothing_and_an_empty_target_stays(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    out.mkdir()
    with pytest.raises(RuntimeError, match="boom"), atomic_folder(out) as tmp:
        tmp.mkdir()
        (tmp / "half.txt").write_text("x")
        raise RuntimeError("boom")
    assert list(out.iterdir()) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]


def test_os_errors_name_the_target_and_a_full_folder_is_kept(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    with pytest.raises(InvalidFile, match="cannot write .*ds"), atomic_folder(out) as tmp:
        tmp.mkdir()  # the rename onto a non-empty folder fails
    assert (out / "mine.txt").read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]
    with pytest.raises(InvalidFile, match="does not exist"), atomic_folder(tmp_path / "no" / "x"):
        pass


def test_a_name_at_the_length_limit_is_written_atomically(tmp_path: Path) -> None:
    """The temporary's extra characters never push a 255-byte name over the limit."""
    from dexlfd.io._atomic import atomic_write, discard, remove_strays, temp_file

    for name in ("a" * 251 + ".npz", "é" * 125 + "a.npz"):  # 255 bytes, ASCII and UTF-8
        target = tmp_path / name
        atomic_write(target, lambda fh: fh.write(b"x"))
        assert target.read_bytes() == b"x"
        tmp = temp_file(target, ".mp4")
        assert len(tmp.name.encode()) <= 255 and tmp.name.endswith(".mp4")
        assert remove_strays(tmp_path) == []  # this run still holds it: not a stray
        discard(tmp)
    assert sorted(len(p.name.encode()) for p in tmp_path.iterdir()) == [255, 255]


@pytest.mark.parametrize("what", ["npz", "csv"])
def test_a_full_disk_is_one_error_and_leaves_nothing(tmp_path: Path, monkeypatch, what) -> None:
    """ENOSPC while writing: one InvalidFile naming the target, no temporary, no second error."""
    import errno
    import gc

    import numpy as np

    from dexlfd.io import Plan, _atomic, save_plan
    from dexlfd.io.csv import export_csv

    real_open = open

    class FullDisk:
        def __init__(self, fh):
            self.fh = fh

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

        def write(self, data):
            self.fh.write(bytes(data)[:10])
            raise OSError(errno.ENOSPC, "No space left on device")

        def __getattr__(self, name):
            return getattr(self.fh, name)

    monkeypatch.setattr(_atomic, "open", lambda p, m: FullDisk(real_open(p, m)), raising=False)
    n = 4
    z = np.zeros((n, 3))
    plan = Plan(
        t=np.arange(n) * 0.1, position=z, velocity=z, acceleration=z,
        quaternion=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)), angular_velocity=z,
        gripper=np.full(n, 0.04),
    )  # fmt: skip
    target = tmp_path / f"p.{what}"
    with pytest.raises(InvalidFile, match=rf"cannot write .*p\.{what}: No space left on device"):
        if what == "npz":
            save_plan(target, plan)
        else:
            export_csv(plan, target)
    gc.collect()  # an unclosed ZipFile's finaliser would raise here (pytest reports it)
    assert list(tmp_path.iterdir()) == []


_HOLDER = """
import sys
from pathlib import Path
from dexlfd.io._atomic import atomic_folder, temp_file
if sys.argv[2] == "folder":
    with atomic_folder(Path(sys.argv[1])) as tmp:
        tmp.mkdir()
        print(tmp.parent, flush=True)
        sys.stdin.read()
else:
    print(temp_file(Path(sys.argv[1]), sys.argv[2]), flush=True)
    sys.stdin.read()
"""


def _writer(target: Path, suffix: str) -> tuple[subprocess.Popen[str], Path]:
    """A process that holds a temporary of ``target`` until its stdin closes."""
    proc = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, str(target), suffix],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stdout is not None
    return proc, Path(proc.stdout.readline().strip())


@pytest.mark.parametrize("kind", ["file", "video", "folder"])
def test_a_killed_runs_temporary_goes_with_the_next_write_a_live_ones_stays(
    tmp_path: Path, kind: str
) -> None:
    """SIGKILL (or a power cut) leaves a temporary; the next write of its target removes it."""
    from dexlfd.io._atomic import atomic_write

    target = tmp_path / ("ds" if kind == "folder" else "m.npz")
    suffix = {"file": "", "video": ".mp4", "folder": "folder"}[kind]
    killed, stray = _writer(target, suffix)
    killed.kill()
    killed.communicate()
    live, held = _writer(target, suffix)
    other, unrelated = _writer(tmp_path / "m.npz.bak", "")
    other.kill()
    other.communicate()
    try:
        assert stray.exists() and held.exists() and unrelated.exists()
        if kind == "folder":
            with atomic_folder(target) as tmp:
                tmp.mkdir()
        else:
            atomic_write(target, lambda fh: fh.write(b"x"))
        assert not stray.exists()  # the killed run's
        assert held.exists()  # another run still writing the same target keeps its own
        assert unrelated.exists()  # another target's strays are its next write's business
    finally:
        live.communicate("")
