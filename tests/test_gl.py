"""The offscreen OpenGL backend is chosen before MuJoCo is imported, or named as missing."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from dexlfd import _gl

REPO = Path(__file__).resolve().parents[1]


def _clean_env(**extra: str) -> dict[str, str]:
    drop = ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    return {**env, "PYTHONPATH": str(REPO / "src"), **extra}


def test_users_setting_and_a_display_are_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    assert _gl.choose_gl_backend() == "osmesa"
    monkeypatch.delenv("MUJOCO_GL")
    monkeypatch.setenv("DISPLAY", ":0")
    assert _gl.choose_gl_backend() is None
    assert "MUJOCO_GL" not in os.environ


def test_headless_picks_the_first_loadable_library(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(_gl, "_loadable", lambda name: name.startswith("libOSMesa"))
    assert _gl.choose_gl_backend() == "osmesa"
    assert os.environ["MUJOCO_GL"] == "osmesa" and os.environ["PYOPENGL_PLATFORM"] == "osmesa"
    monkeypatch.delenv("MUJOCO_GL")
    monkeypatch.delenv("PYOPENGL_PLATFORM")
    monkeypatch.setattr(_gl, "_loadable", lambda name: False)
    assert _gl.choose_gl_backend() is None and "MUJOCO_GL" not in os.environ


def test_renderer_without_opengl_is_one_line_naming_the_packages() -> None:
    class Broken:
        def Renderer(self, *args: object) -> None:
            raise RuntimeError("an OpenGL platform library has not been loaded\ninto this process")

    with pytest.raises(_gl.RenderingUnavailable) as info:
        _gl.make_renderer(Broken(), None, 48, 64)
    msg = str(info.value)
    assert "\n" not in msg and "libegl1" in msg and "libosmesa6" in msg
    assert "an OpenGL platform library has not been loaded into this process" in msg


@pytest.mark.slow
def test_headless_rendering_works_without_mujoco_gl_set() -> None:
    """With no MUJOCO_GL and no display, a frame renders (EGL here) in a fresh process."""
    code = (
        "import os\n"
        "from dexlfd.panda import Q_READY\n"
        "from dexlfd.robot import PlantConfig\n"
        "from dexlfd.robot.sim import PandaSim\n"
        "with PandaSim(PlantConfig(), Q_READY) as sim:\n"
        "    img = sim.render(64, 48)\n"
        "print(os.environ['MUJOCO_GL'], img.shape, int(img.std() > 0))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=_clean_env(), timeout=300)  # fmt: skip
    if out.returncode != 0 and "RenderingUnavailable" in out.stderr:
        pytest.skip(f"no OpenGL library on this machine: {out.stderr.splitlines()[-1]}")
    assert out.returncode == 0, out.stderr
    backend, *rest = out.stdout.split(maxsplit=1)
    assert backend in ("egl", "osmesa") and rest == ["(48, 64, 3) 1\n"]


@pytest.mark.slow
def test_rendering_works_when_mujoco_was_imported_first() -> None:
    """A script that imports mujoco before dexlfd (MuJoCo then fixes GLFW) still renders."""
    code = (
        "import mujoco\n"
        "from dexlfd.panda import Q_READY\n"
        "from dexlfd.robot import PlantConfig\n"
        "from dexlfd.robot.sim import PandaSim\n"
        "with PandaSim(PlantConfig(), Q_READY) as sim:\n"
        "    img = sim.render(64, 48)\n"
        "print(img.shape, int(img.std() > 0))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=_clean_env(), timeout=300)  # fmt: skip
    if out.returncode != 0 and "RenderingUnavailable" in out.stderr and "DISPLAY" not in out.stderr:
        pytest.skip(f"no OpenGL library on this machine: {out.stderr.splitlines()[-1]}")
    assert out.returncode == 0, out.stderr
    assert out.stdout == "(48, 64, 3) 1\n"


@pytest.mark.slow
def test_a_process_that_rendered_draws_its_background_stage_itself(tmp_path: Path) -> None:
    """A forked child of a process with an OpenGL context hangs at its first frame in
    Mesa: a stage that renders stays in such a process, and draws there."""
    code = (
        "import os, sys\n"
        "from pathlib import Path\n"
        "from dexlfd.apps._stages import Stage, StageRunner\n"
        "from dexlfd.panda import Q_READY\n"
        "from dexlfd.robot import PlantConfig\n"
        "from dexlfd.robot.sim import PandaSim\n"
        "def draw(out):\n"
        "    with PandaSim(PlantConfig(), Q_READY) as sim:\n"
        "        img = sim.render(64, 48)\n"
        "    return {}, {'pid': os.getpid(), 'drawn': int(img.std() > 0)}\n"
        "draw(None)\n"
        "res = StageRunner(Path(sys.argv[1])).run(\n"
        "    [Stage('v', 'V', 'v', draw, background=True, renders=True)])\n"
        "s = res['v']['summary']\n"
        "print(int(s['pid'] == os.getpid()), s['drawn'])\n"
    )
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True,
                         text=True, env=_clean_env(), timeout=600)  # fmt: skip
    if out.returncode != 0 and "RenderingUnavailable" in out.stderr:
        pytest.skip(f"no OpenGL library on this machine: {out.stderr.splitlines()[-1]}")
    assert out.returncode == 0, out.stderr
    assert out.stdout == "1 1\n"
