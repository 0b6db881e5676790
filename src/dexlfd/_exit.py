"""The ``dexlfd`` process's exit without the interpreter's teardown, when that is safe.

After a command returns, Python frees every module it loaded (MediaPipe, OpenCV, numba
with its kernels, SciPy, MuJoCo, matplotlib): 0.5-0.9 s of CPU after ``teach`` had
written everything (measured on a quiet 2-core machine: 0.65 s of wall). The process
leaves by ``os._exit`` instead, after doing what that teardown would have done for
the files: the ``atexit`` handlers run (logging's handlers flushed and closed,
multiprocessing's children reaped, temporary folders removed) and stdout and stderr
flushed. It does so only when it can see that nothing else is left to finish:

* no thread but daemon ones (a worker still running: the normal exit waits for it);
* no regular file still open for writing (``/proc/self/fd``: its buffered bytes would be
  lost), so Linux only; elsewhere the normal exit. A file without a name left (the
  shared memory of ``multiprocessing``'s values, which the robot video's renderer uses)
  does not count: nothing can read it once the process is gone.

Otherwise (or when ``DEXLFD_NO_FAST_EXIT`` is set) it is the normal ``sys.exit``.
"""

from __future__ import annotations

import atexit
import os
import stat
import sys
import threading
from typing import NoReturn

__all__ = ["exit_process", "files_open_for_writing"]

_WRITE = os.O_WRONLY | os.O_RDWR


def files_open_for_writing() -> list[str] | None:
    """Named regular files this process holds open for writing (None: cannot tell, not Linux)."""
    fds = "/proc/self/fd"
    if not os.path.isdir(fds):
        return None
    found = []
    for name in os.listdir(fds):
        try:
            st = os.stat(f"{fds}/{name}")
            if not stat.S_ISREG(st.st_mode) or st.st_nlink == 0:
                continue  # an unlinked file (shared memory): no one reads it after us
            with open(f"/proc/self/fdinfo/{name}") as fh:
                flags = next(int(v.split()[1], 8) for v in fh if v.startswith("flags:"))
            if flags & _WRITE:
                found.append(os.readlink(f"{fds}/{name}"))
        except (OSError, StopIteration, ValueError):
            continue  # closed meanwhile (the listing's own descriptor), or not a file
    return found


def _others_running() -> bool:
    main = threading.main_thread()
    return any(t is not main and not t.daemon and t.is_alive() for t in threading.enumerate())


def exit_process(code: int) -> NoReturn:
    """End the process with ``code``: os._exit when safe (see the module), else sys.exit."""
    if os.environ.get("DEXLFD_NO_FAST_EXIT") or _others_running():
        sys.exit(code)
    atexit._run_exitfuncs()  # what the normal exit runs first; each runs once
    if files_open_for_writing() != [] or _others_running():
        sys.exit(code)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: the normal exit would say so
            sys.exit(code)
    os._exit(code)
