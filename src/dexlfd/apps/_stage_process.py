"""A stage run in a forked child of the run (:mod:`dexlfd.apps._stages`).

The child logs into a queue that the run's process reads in a thread and logs as its
own records (above its progress bar; a test's log capture sees them). Before the child
sends its result it flushes its records into the queue, and receiving the result waits
until the run has logged every one of them: a stage's lines come before its ``done``.

The child ends with the run: on Linux it is killed when the run's process dies (even
by SIGKILL, which no ``finally`` sees), so no orphan goes on tracking a video for
nobody. An error it raises is raised in the run as the same exception, the child's
traceback added as a note; one that cannot cross the pipe (its class takes other
arguments than its message) as a :class:`~dexlfd.errors.DexlfdError` of the same text.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import logging.handlers
import multiprocessing
import os
import pickle
import resource
import signal
import sys
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dexlfd.errors import DexlfdError

__all__ = ["LogQueue", "Running", "cpu_seconds", "start_child"]

_PR_SET_PDEATHSIG = 1  # prctl(2): the signal this process gets when its parent dies


def cpu_seconds() -> float:
    """CPU time of this process and of every child it waited for (workers, ffmpeg) [s]."""
    own, kids = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


class _Forward(logging.Handler):
    """A record from a background stage, logged by the parent as its own logger would."""

    def emit(self, record: logging.LogRecord) -> None:
        logging.getLogger(record.name).handle(record)


class LogQueue:
    """The queue the children log into, its records logged here (in a thread) as they come."""

    def __init__(self) -> None:
        self.queue: Any = multiprocessing.get_context("fork").Queue()
        self._listener = logging.handlers.QueueListener(self.queue, _Forward())

    def __enter__(self) -> LogQueue:
        self._listener.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self._listener.stop()  # the records already queued are logged first
        self.queue.close()

    def drain(self) -> None:
        """Return once every record queued before this call is logged."""
        self._listener.stop()
        self._listener.start()


def _end_with_parent(parent: int) -> None:  # pragma: no cover - in the child
    """Be killed when the parent dies (Linux); gone already: end now."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None).prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL))
    if os.getppid() != parent:
        os._exit(1)


def _portable(exc: BaseException) -> BaseException | None:
    """``exc`` with the child's traceback as a note, if it survives a pickle; else a stand-in."""
    exc.add_note("in the stage's process:\n" + "".join(traceback.format_exception(exc)).rstrip())
    try:
        pickle.loads(pickle.dumps(exc))
    except Exception:  # noqa: BLE001 - e.g. an __init__ that takes other arguments
        if not isinstance(exc, DexlfdError):
            return None
        return DexlfdError(str(exc), param=exc.param)
    return exc


def _child(
    stage: Any, out: Path, conn: Any, logs: Any, parent: int
) -> None:  # pragma: no cover - in the child
    _end_with_parent(parent)
    if stage.nice:  # Stage.nice: yield the cores to the run's critical path
        with contextlib.suppress(OSError):
            os.nice(stage.nice)
    dexlfd_logger = logging.getLogger("dexlfd")
    dexlfd_logger.handlers[:] = [logging.handlers.QueueHandler(logs)]
    t0, c0 = time.perf_counter(), cpu_seconds()
    try:
        result = stage.run(out)
        message: tuple[Any, ...] = (
            "ok", result, time.perf_counter() - t0, cpu_seconds() - c0
        )  # fmt: skip
    except BaseException as exc:
        message = ("error", f"{type(exc).__name__}: {exc}", _portable(exc))
    dexlfd_logger.handlers[:] = [logging.NullHandler()]
    logs.close()
    logs.join_thread()  # every record is in the queue before the result is sent
    try:
        conn.send(message)
    except Exception:  # the result itself may not pickle: the error's text does
        conn.send(message[:2] + (None,))
    conn.close()


@dataclass
class Running:
    """A stage running in a forked child; :meth:`result` waits for it."""

    stage: Any
    process: Any
    conn: Any
    logs: LogQueue

    def result(self) -> tuple[tuple[dict[str, Path], dict[str, Any]], float, float]:
        """The stage's outputs and summary, its seconds and CPU seconds; raises its error."""
        try:
            message = self.conn.recv()
        except EOFError:
            self.process.join()
            raise DexlfdError(
                f"stage {self.stage.name}: its process died (exit code {self.process.exitcode})"
            ) from None
        finally:
            self.conn.close()
        self.process.join()
        self.logs.drain()
        if message[0] == "error":
            if isinstance(message[2], BaseException):
                raise message[2]
            raise DexlfdError(f"stage {self.stage.name}: {message[1]}")
        return message[1], message[2], message[3]

    def stop(self) -> None:
        """End the child (if it still runs) and wait for it."""
        if self.process.is_alive():
            self.process.terminate()
        self.process.join()
        self.conn.close()


def start_child(stage: Any, out: Path, logs: LogQueue) -> Running:
    """Fork a child that runs ``stage.run(out)`` and sends its result back."""
    ctx = multiprocessing.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    process = ctx.Process(target=_child, args=(stage, out, send, logs.queue, os.getpid()),
                          name=f"dexlfd-{stage.name}")  # fmt: skip
    process.start()
    send.close()
    return Running(stage, process, recv, logs)
