"""SIGTERM and SIGHUP stop a run the way Ctrl-C does, in one place: the CLI's entry.

``kill``, systemd, Docker and CI runners stop a process with SIGTERM; closing its
terminal sends SIGHUP. By default either kills Python at once: no ``finally`` runs, so
temporaries (``.dexlfd-part``) stay behind and worker pools, forked stage processes and
ffmpeg keep running. Under :func:`stop_signals_as_interrupts` both raise
:class:`Terminated`, a :class:`KeyboardInterrupt`, so every cleanup that Ctrl-C already
runs (atomic writers removing their temporaries, :mod:`dexlfd.engine` terminating its
workers, the demo's stages stopping their children, the video writer killing ffmpeg)
runs for them too, and :func:`exit_code` gives the shell's convention: 128 + the
signal's number (130 SIGINT, 143 SIGTERM, 129 SIGHUP).

A signal ignored when the run starts stays ignored (``nohup dexlfd ...`` keeps running
when its terminal closes). Only the first SIGTERM or SIGHUP raises: a second one while
the cleanup runs is noted and dropped, so it cannot cut that cleanup short (SIGKILL
still ends a run at once). A child forked by the run (``os.fork``, multiprocessing's
``fork``) starts with both at their defaults, so its parent's ``terminate()`` ends it.

A handler that runs inside a ctypes callback (numba's compiler calls llvmlite's object
cache through one) raises there, where CPython reports the exception as "ignored" and
carries on: the run would finish as if it had never been stopped (exit 0). For the
duration, :func:`_lost_stop` (``sys.unraisablehook``) takes that report and raises the
same stop again at the next Python call or return after the callback (a one-shot
``sys.setprofile``), where it propagates as any other.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

__all__ = ["Terminated", "deferred", "describe", "exit_code", "stop_signals_as_interrupts"]

STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
_NAMES = {signal.SIGTERM: "terminated (SIGTERM)", signal.SIGHUP: "hung up (SIGHUP)"}
_raised = False  # a stop signal was already turned into Terminated in this run


class Terminated(KeyboardInterrupt):
    """A run stopped by SIGTERM or SIGHUP (``signum``); cleaned up like Ctrl-C."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = int(signum)


def _raise(signum: int, frame: FrameType | None) -> None:
    global _raised
    if _raised:  # the first one is being handled: let its cleanup finish
        return
    _raised = True
    raise Terminated(signum)


def _lost_stop(unraisable: Any) -> None:
    """``sys.unraisablehook``: a stop a callback swallowed is raised again once it returned."""
    exc = unraisable.exc_value
    if not isinstance(exc, KeyboardInterrupt) or threading.current_thread() is not (
        threading.main_thread()
    ):
        _previous_hook[-1](unraisable)
        return
    profiler = sys.getprofile()
    here = _lost_stop.__code__

    def raise_again(frame: FrameType, event: str, arg: object) -> None:
        if frame.f_code is here:  # this hook's own return: still inside the callback
            return
        sys.setprofile(profiler)
        raise exc

    sys.setprofile(raise_again)


_previous_hook: list[Any] = []  # the hooks stop_signals_as_interrupts replaced (nested)


def _defaults_in_child() -> None:  # pragma: no cover - runs in forked children
    for sig in STOP_SIGNALS:
        if signal.getsignal(sig) is _raise:
            signal.signal(sig, signal.SIG_DFL)


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_defaults_in_child)


@contextmanager
def stop_signals_as_interrupts() -> Iterator[None]:
    """SIGTERM and SIGHUP raise :class:`Terminated` for the duration (main thread only).

    Signals that were ignored on entry stay ignored; the previous handlers are restored
    on exit (the CLI's :func:`~dexlfd.cli.main` also runs inside test processes).
    """
    global _raised
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {}
    for sig in STOP_SIGNALS:
        current = signal.getsignal(sig)
        if current is signal.SIG_IGN:
            continue
        previous[sig] = current
        signal.signal(sig, _raise)
    _raised = False
    _previous_hook.append(sys.unraisablehook)
    sys.unraisablehook = _lost_stop
    try:
        yield
    finally:
        sys.unraisablehook = _previous_hook.pop()
        for sig, handler in previous.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


@contextmanager
def deferred() -> Iterator[None]:
    """Hold Ctrl-C, SIGTERM and SIGHUP for the duration; raise the first one after it.

    For the few steps that must not be cut in two: starting a worker process (one whose
    start was interrupted is launched but unknown to its pool, so nobody stops it and it
    dies later on the pool's freed queues, with a traceback). Signals this run does not
    turn into exceptions are left alone; outside the main thread this does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []
    previous = {}
    for sig in (signal.SIGINT, *STOP_SIGNALS):
        current = signal.getsignal(sig)
        if current is _raise or current is signal.default_int_handler:
            previous[sig] = current
            signal.signal(sig, lambda signum, frame: held.append(signum))
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if held:
        first = held[0]
        if first == signal.SIGINT:
            raise KeyboardInterrupt
        _raise(first, None)


def exit_code(exc: KeyboardInterrupt) -> int:
    """128 + the signal's number: 143 for SIGTERM, 129 for SIGHUP, 130 for Ctrl-C."""
    return 128 + (exc.signum if isinstance(exc, Terminated) else int(signal.SIGINT))


def describe(exc: KeyboardInterrupt) -> str:
    """``"interrupted"`` for Ctrl-C, ``"terminated (SIGTERM)"``, ``"hung up (SIGHUP)"``."""
    if isinstance(exc, Terminated):
        return _NAMES.get(signal.Signals(exc.signum), f"stopped by signal {exc.signum}")
    return "interrupted"
