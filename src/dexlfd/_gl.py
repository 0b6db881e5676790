"""Choose MuJoCo's OpenGL backend for offscreen rendering, and say what is missing.

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is imported; its default (GLFW)
needs a display. :func:`choose_gl_backend` runs before that import
(:func:`dexlfd.robot.robot_model.import_mujoco`, the one place that imports MuJoCo): a
``MUJOCO_GL`` the user set is kept, a machine with a display keeps GLFW, and a
headless Linux machine gets EGL when ``libEGL`` loads, else OSMesa when
``libOSMesa`` loads. :func:`make_renderer` turns a failure to create the context
into one line naming the Debian packages that provide these libraries.

An OpenGL context does not survive a fork: Mesa's software renderer keeps worker
threads that the forked child does not have, and its first read of the pixels waits
for them forever. :func:`context_made` says whether this process (or one it was forked
from) made one, so that work which forks (a stage run in the background) can stay in
this process instead.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
from typing import Any

from dexlfd.errors import DexlfdError

__all__ = [
    "GL_LIBRARIES",
    "RenderingUnavailable",
    "choose_gl_backend",
    "context_made",
    "make_renderer",
]

#: backend -> shared libraries tried in order (any one that loads will do)
GL_LIBRARIES: dict[str, tuple[str, ...]] = {
    "egl": ("libEGL.so.1", "libEGL.so"),
    "osmesa": ("libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"),
}
_HINT = (
    "no OpenGL for offscreen rendering: install EGL (Debian: apt-get install libegl1 "
    "libgl1-mesa-dri) or OSMesa (apt-get install libosmesa6), or set MUJOCO_GL"
)


class RenderingUnavailable(DexlfdError):
    """No OpenGL context can be made for MuJoCo's offscreen renderer."""


def _loadable(name: str) -> bool:
    try:
        ctypes.CDLL(name)
    except OSError:
        return False
    return True


def choose_gl_backend() -> str | None:
    """Set ``MUJOCO_GL`` (if unset) to a backend that can work here; returns the backend.

    Returns the user's ``MUJOCO_GL`` if set; None when MuJoCo's own default is
    kept (a display is available, not Linux, or no OpenGL library was found: the
    renderer then fails with :class:`RenderingUnavailable` and the hint).
    """
    if os.environ.get("MUJOCO_GL"):
        return os.environ["MUJOCO_GL"]
    if not sys.platform.startswith("linux"):
        return None
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return None
    for backend, libraries in GL_LIBRARIES.items():
        if any(_loadable(name) for name in libraries):
            os.environ["MUJOCO_GL"] = backend
            os.environ.setdefault("PYOPENGL_PLATFORM", backend)
            return backend
    return None


def _match_context() -> None:
    """Point MuJoCo's context class at the chosen backend if MuJoCo fixed another.

    MuJoCo picks its context class (``mujoco.rendering.classic.gl_context``) when it
    is imported. A program that imported ``mujoco`` before dexlfd chose a backend (a
    user's script, a test module) got GLFW, which needs a display, although EGL or
    OSMesa is installed; the renderer reads the class when it is made, so the class of
    the backend in ``MUJOCO_GL`` is put there.
    """
    backend = os.environ.get("MUJOCO_GL", "").lower().strip()
    if backend not in GL_LIBRARIES:
        return
    try:
        glc = importlib.import_module("mujoco.rendering.classic.gl_context")
    except Exception:  # another MuJoCo layout, or no OpenGL: the renderer says which
        return
    if getattr(glc, "_MUJOCO_GL", backend) == backend:
        return
    os.environ.setdefault("PYOPENGL_PLATFORM", backend)
    try:
        context = importlib.import_module(f"mujoco.{backend}").GLContext
    except Exception:  # that backend cannot load here: MuJoCo's choice stands, and
        return  # the renderer's own error says what fails
    glc.GLContext = context  # type: ignore[attr-defined]


_context_made = False  # inherited by a forked child, which cannot use the context


def context_made() -> bool:
    """Whether this process, or a process it was forked from, made an OpenGL context.

    Such a process must not render in a forked child (the child hangs in Mesa).
    """
    return _context_made


def make_renderer(mj: Any, model: Any, height: int, width: int) -> Any:
    """``mujoco.Renderer(model, height, width)``, or :class:`RenderingUnavailable` in one line."""
    global _context_made
    _match_context()
    _context_made = True  # set before the attempt: a half-made context has threads too
    try:
        return mj.Renderer(model, height, width)
    except Exception as exc:  # MuJoCo/PyOpenGL raise several types for a missing context
        backend = os.environ.get("MUJOCO_GL") or "glfw (MuJoCo's default)"
        detail = " ".join(str(exc).split()) or type(exc).__name__
        raise RenderingUnavailable(f"{_HINT} (MUJOCO_GL={backend}: {detail})") from exc
