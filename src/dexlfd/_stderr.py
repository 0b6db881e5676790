"""Native libraries' stderr silenced while ours still reaches the terminal."""

from __future__ import annotations

import contextlib
import faulthandler
import logging
import os
import sys
import threading
from collections.abc import Iterator
from typing import TextIO

__all__ = ["native_stderr_silenced"]

_lock = threading.Lock()
_depth = 0  # nested uses: only the outermost redirects


@contextlib.contextmanager
def native_stderr_silenced(active: bool = True) -> Iterator[None]:
    """File descriptor 2 to /dev/null for the duration; our own messages still shown.

    MediaPipe's C++ graph (absl ``W0000 ...`` lines, "Created TensorFlow Lite XNNPACK
    delegate", some from its own threads at any time) and ffmpeg ("moov atom not
    found") write straight to fd 2, and no setting of mediapipe 0.10.21 turns absl's
    off. Here fd 2 goes to /dev/null, while ``sys.stderr`` (when it is fd 2: our log
    handler, progress bars, Python errors) and the ``dexlfd`` log handlers write to a
    copy of the original descriptor. :mod:`faulthandler` also writes there, so a
    native crash (abort, segfault) still prints its reason and Python traceback
    instead of dying silently. Nested uses keep the outer redirection.
    ``DEXLFD_MEDIAPIPE_LOGS=1`` (or ``active=False``) keeps the native lines.
    """
    global _depth
    if not active or os.environ.get("DEXLFD_MEDIAPIPE_LOGS") == "1":
        yield
        return
    with _lock:
        outer = _depth == 0
        _depth += 1
    if not outer:
        try:
            yield
        finally:
            with _lock:
                _depth -= 1
        return
    old = sys.stderr
    try:
        on_fd2 = old.fileno() == 2  # not when captured (pytest) or redirected in Python
    except (AttributeError, OSError, ValueError):
        on_fd2 = False
    handlers = [
        h
        for h in logging.getLogger("dexlfd").handlers
        if on_fd2 and isinstance(h, logging.StreamHandler) and h.stream is old
    ]
    fault_was_on = faulthandler.is_enabled()
    saved: int | None = None
    ours: TextIO | None = None
    devnull: int | None = None
    try:
        old.flush()
        saved = os.dup(2)
        ours = os.fdopen(saved, "w", buffering=1, encoding="utf-8", errors="replace")
        devnull = os.open(os.devnull, os.O_WRONLY)
        faulthandler.enable(file=ours, all_threads=True)
        os.dup2(devnull, 2)
        if on_fd2:
            sys.stderr = ours
        for h in handlers:
            h.setStream(ours)
        yield
    finally:
        if saved is not None:
            if ours is not None:
                ours.flush()
            os.dup2(saved, 2)
        sys.stderr = old
        for h in handlers:
            h.setStream(old)
        if fault_was_on and sys.__stderr__ is not None:  # its earlier file is unknown
            with contextlib.suppress(AttributeError, OSError, ValueError):
                faulthandler.enable(file=sys.__stderr__, all_threads=True)
        else:
            faulthandler.disable()
        if ours is not None:
            ours.close()  # closes saved
        elif saved is not None:
            os.close(saved)
        if devnull is not None:
            os.close(devnull)
        with _lock:
            _depth -= 1
