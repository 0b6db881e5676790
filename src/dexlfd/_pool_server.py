"""The helper processes of the local process pools, stopped before their process exits.

A pool on multiprocessing's fork server (:func:`dexlfd.engine.map_items`) starts two
helpers in the process that makes it: the fork server, which forks the workers, and
the resource tracker. Both are kept for the process's later pools and left to notice
on their own that it is gone: they then finish (a fork server that preloaded dexlfd
takes a second or more at a loaded machine's pace) after the command has exited, and
its process group is not empty when its parent sees it end (``dexlfd demo``'s payload
study left them up to 3 s). :func:`claim` notes, as a pool is made, which helpers that
process is about to start, and has :func:`shutdown_pool_server` stop them when the
process exits (the main process at interpreter exit; a multiprocessing child, such as
a background stage of ``dexlfd demo``, at the end of its run) and wait for them.
"""

from __future__ import annotations

import contextlib
import os
from multiprocessing import forkserver, resource_tracker, util

__all__ = ["claim", "shutdown_pool_server"]

# helper -> pid of the process that started it (a forked child inherits the parent's
# entries: it stops only the helpers it started itself)
_owned: dict[str, int] = {}
_at_exit: set[int] = set()  # processes whose exit stops their helpers


def _server() -> object:
    return forkserver._forkserver  # noqa: SLF001 - see claim


def _tracker() -> object:
    return resource_tracker._resource_tracker  # noqa: SLF001 - see claim


def claim() -> None:
    """Before a fork-server pool is made: own the helpers this process will start.

    The helpers are multiprocessing's module singletons; whether one runs is its pid
    (None before it starts). Only those not running yet are this process's to stop.
    """
    me = os.getpid()
    if getattr(_server(), "_forkserver_pid", 0) is None:
        _owned["forkserver"] = me
    if getattr(_tracker(), "_pid", 0) is None:
        _owned["tracker"] = me
    if me not in _at_exit:
        _at_exit.add(me)
        # after multiprocessing has joined this process's children (priority < 0)
        util.Finalize(None, shutdown_pool_server, exitpriority=-10)


def shutdown_pool_server() -> None:
    """Stop the fork server and resource tracker this process started, and wait for them.

    A no-op for helpers another process started or none; a later pool starts them
    again. Called by itself at exit (see the module); call it to end them sooner.
    """
    me = os.getpid()
    for name, helper in (("forkserver", _server()), ("tracker", _tracker())):
        if _owned.get(name) == me:
            del _owned[name]
            stop = getattr(helper, "_stop", None)
            if stop is not None:
                with contextlib.suppress(OSError):  # already gone (reaped elsewhere)
                    stop()  # closes its "alive" pipe, then waits for it to exit
