"""A dependency that is installed but no longer imports (a broken OpenCV) is one line."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from dexlfd.errors import broken_import, import_culprit

REPO = Path(__file__).resolve().parents[1]

# cv2 made unimportable in the child: either refused outright (what Python raises when
# sys.modules holds None for it) or an installed-looking cv2 package whose import fails
# inside its own files, as a second OpenCV distribution's removal leaves it
HALTED = "import sys; sys.modules['cv2'] = None\n"
CALL = "from dexlfd.cli import main\nsys.exit(main(['record', {video!r}, '-o', {out!r}]))\n"


def _record_with_broken_cv2(tmp_path: Path, prelude: str, extra_path: Path | None) -> tuple:
    from dexlfd.data import hand_video

    out = tmp_path / "demo.npz"
    code = "import sys\n" + prelude + CALL.format(video=str(hand_video()), out=str(out))
    env = dict(os.environ)
    paths = [str(p) for p in (extra_path, REPO / "src") if p is not None]
    env["PYTHONPATH"] = os.pathsep.join([*paths, env.get("PYTHONPATH", "")])
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
        check=False, timeout=300,
    )  # fmt: skip
    return done, out


def _errors(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if not line.startswith(("W ", "I "))]


def test_record_with_cv2_refused_says_one_line(tmp_path: Path) -> None:
    done, out = _record_with_broken_cv2(tmp_path, HALTED, None)
    assert done.returncode == 1
    (line,) = _errors(done.stderr)
    assert line.startswith("dexlfd record: error: OpenCV (cv2) cannot be imported")
    assert "pip install --force-reinstall opencv-contrib-python" in line
    assert "Traceback" not in done.stderr and not out.exists()


def test_record_with_a_cv2_that_fails_inside_its_package_says_one_line(tmp_path: Path) -> None:
    site = tmp_path / "lib" / "site-packages"
    (site / "cv2").mkdir(parents=True)
    (site / "cv2" / "__init__.py").write_text(
        "raise ImportError('libopencv_core.so.412: cannot open shared object file')\n"
    )
    done, out = _record_with_broken_cv2(tmp_path, "", site)
    assert done.returncode == 1
    (line,) = _errors(done.stderr)
    assert line.startswith("dexlfd record: error: OpenCV (cv2) cannot be imported (libopencv")
    assert not out.exists()


def test_import_culprit_names_the_package_or_nothing() -> None:
    assert import_culprit(ModuleNotFoundError("x", name="cv2.utils")) == "cv2"
    assert import_culprit(ImportError("no name, no traceback")) == ""
    with pytest.raises(ImportError) as info:
        import dexlfd_no_such_module  # type: ignore[import-not-found]  # noqa: F401
    assert import_culprit(info.value) == "dexlfd_no_such_module"
    assert "pip install --force-reinstall numpy" in broken_import(
        ModuleNotFoundError("broken", name="numpy.core")
    )


def test_a_bug_in_our_own_imports_is_not_hidden_as_a_broken_dependency(
    tmp_path: Path,
) -> None:
    prelude = (
        "import dexlfd.capture.opencv_sources as m\n"
        "def _broken():\n"
        "    import dexlfd.no_such_module\n"
        "m._cv2 = _broken\n"
    )
    done, _ = _record_with_broken_cv2(tmp_path, prelude, None)
    assert done.returncode != 0
    assert "Traceback" in done.stderr and "dexlfd.no_such_module" in done.stderr
