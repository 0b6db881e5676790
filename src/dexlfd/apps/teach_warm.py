"""``teach``'s later stages made ready in a thread while ``record`` tracks the videos.

Tracking a video leaves one of two cores partly idle (MediaPipe and OpenCV run in
native code). What the stages after ``record`` would otherwise load on the critical
path is loaded then, in a thread of this process (a forked child's imports would not
warm this one): the modules of frame, learn, plan, simulate and the report, MuJoCo,
the planner's and the control tick's numba kernels (from numba's on-disk cache, or
compiled on a fresh install), and the drawing modules the background stages use (a
forked stage starts with what this process has loaded). Nothing it does changes a
result: it only moves work the stages would do themselves earlier.

The thread starts once the first frame is tracked (the tracker's own imports are done
by then: two threads importing the same package at once can find each other's
half-imported modules) and is waited for when ``record`` ends, before any stage forks.
While it runs, Python switches threads more often (:data:`SWITCH_INTERVAL_S`), so that
the tracking is not kept waiting for the GIL.
"""

from __future__ import annotations

import importlib
import logging
import sys
import threading
from collections.abc import Callable
from types import TracebackType

__all__ = ["SWITCH_INTERVAL_S", "WARM_MODULES", "WarmUp", "warm_up"]

logger = logging.getLogger(__name__)

# [s] Python's thread switch interval while the warm-up runs (default 5 ms): the tracking
# thread, back from native code, waits for the warm-up thread to let go of the GIL for
# up to this long, several times a frame. Measured (a frame of four 1080p resizes and
# blurs beside the warm-up, loaded machine): 2.6-5.0x a frame's time alone at 5 ms,
# 1.2-3.2x at 0.5 ms.
SWITCH_INTERVAL_S = 5e-4

#: what the stages after ``record`` import (this process's and the forked ones'), the
#: heaviest first; scipy.optimize is also what ``record`` imports at its end
WARM_MODULES = (
    "scipy.optimize",
    "dexlfd.plan.pipeline",
    "dexlfd.robot",
    "dexlfd.robot.arm_posture",
    "dexlfd.control",
    "dexlfd.control.loop",
    "dexlfd.apps.teach_frame",
    "dexlfd.apps.teach_align",
    "dexlfd.apps.teach_figures",
    "dexlfd.apps.teach_robot",
    "dexlfd.apps.teach_report",
    "dexlfd.viz.demonstrations",
    "dexlfd.viz.learning",
    "dexlfd.viz.teach",
    "dexlfd.viz.control",
    "dexlfd.viz.robot_video",
)


def warm_up() -> int:
    """Import :data:`WARM_MODULES` and MuJoCo, load the numba kernels; returns the kernels."""
    from dexlfd.robot.robot_model import import_mujoco

    for name in WARM_MODULES:
        importlib.import_module(name)
    import_mujoco()
    from dexlfd.control.tick_kernels import warm_kernels as warm_tick_kernels
    from dexlfd.plan.kernels import warm_kernels

    return warm_kernels() + warm_tick_kernels()


class WarmUp:
    """:func:`warm_up` (or ``work``) in a thread from :meth:`start` until the block ends.

    :meth:`start` may be called many times (once a frame): the first call starts the
    thread. Leaving the ``with`` block waits for it. A failure is logged and otherwise
    ignored: the stages then load what they need themselves.
    """

    def __init__(self, work: Callable[[], object] = warm_up) -> None:
        self._work = work
        self._thread: threading.Thread | None = None

    def start(self, *_args: object) -> None:
        """Start the thread (the first call only); any arguments are ignored."""
        if self._thread is not None:
            return
        from dexlfd._gl import choose_gl_backend

        choose_gl_backend()  # sets MUJOCO_GL here: not from a thread beside native code
        self._thread = threading.Thread(target=self._run, name="dexlfd-warm-up", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        interval = sys.getswitchinterval()
        sys.setswitchinterval(min(interval, SWITCH_INTERVAL_S))
        try:
            self._work()
        except Exception as exc:  # noqa: BLE001 - any failure: the stages load it themselves
            logger.debug("warm-up stopped (%s): the stages load what they need", exc)
        finally:
            sys.setswitchinterval(interval)

    def wait(self) -> None:
        """Wait for the thread (if started): this thread may then import what it imported."""
        if self._thread is not None:
            self._thread.join()

    def __enter__(self) -> WarmUp:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.wait()
