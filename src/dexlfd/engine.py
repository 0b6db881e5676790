"""Run independent items in parallel: in-process, a local process pool, or Ray.

Tracking many videos and repeating a controller study over many random plants
are embarrassingly parallel: every item is computed from its own input alone.
:func:`map_items` runs ``fn(item)`` for each item on the chosen engine and
returns one :class:`ItemOutcome` per item, in input order:

- ``engine="local"``: ``workers=1`` runs in this process; more workers use a
  :class:`concurrent.futures.ProcessPoolExecutor` fed by a fork server (so
  ``fn`` and the items are pickled, as for Ray), kept for later calls and stopped,
  waited for, before this process exits (:mod:`dexlfd._pool_server`).
- ``engine="ray"``: a local Ray cluster with ``num_cpus=workers`` (started on
  first use, kept for later calls until :func:`shutdown_ray` or exit), a running
  cluster at ``address``, or this process's own Ray connection (left open).
  Items go in chunks (``CHUNKS_PER_SLOT`` tasks per slot), ``workers`` at once.

Every item runs with one BLAS thread (so that a process pool, Ray's
single-threaded workers and this process sum in the same order). A failing item
becomes an outcome with a one-line ``error`` (and a warning at the end listing
every failure); the other items still run. Results never depend on the engine
or the worker count as long as ``fn`` takes its randomness from the item: derive
it with :func:`item_seed` from the study's seed and the item's index.

Examples
--------
>>> outcomes = map_items(abs, [-1, 2], labels=["a", "b"])
>>> [o.value for o in outcomes]
[1, 2]
"""

from __future__ import annotations

import atexit
import logging
import multiprocessing
import os
import shutil
import signal
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._pool_server import claim
from dexlfd._signals import deferred
from dexlfd.errors import InvalidInput

__all__ = [
    "ENGINES",
    "ItemOutcome",
    "format_failures",
    "item_seed",
    "map_items",
    "shutdown_ray",
]

logger = logging.getLogger(__name__)

ENGINES = ("local", "ray")
MAX_ERROR_CHARS = 300  # an item's error stays one readable line


@dataclass(frozen=True, slots=True)
class ItemOutcome:
    """What became of one item.

    Attributes
    ----------
    index : int
        Position of the item in the input.
    label : str
        The caller's name for it (a file name, ``"trial 7"``).
    value : Any
        ``fn(item)``; None when the item failed.
    error : str or None
        ``"ExceptionType: message"`` on one line, or None on success.
    seconds : float
        Wall time of ``fn(item)`` in the worker [s].
    cpu_seconds : float
        CPU time of the worker process during ``fn(item)`` [s].
    """

    index: int
    label: str
    value: Any = None
    error: str | None = None
    seconds: float = 0.0
    cpu_seconds: float = 0.0

    @property
    def ok(self) -> bool:
        """True when the item succeeded."""
        return self.error is None


def item_seed(seed: int, index: int) -> np.random.SeedSequence:
    """The seed sequence of item ``index`` of a study seeded with ``seed``.

    Equal to ``np.random.SeedSequence(seed).spawn(n)[index]`` for any
    ``n > index``: independent streams per item that depend on nothing but the
    study seed and the item's position.
    """
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InvalidInput(f"seed must be an integer >= 0, got {seed!r}")
    if isinstance(index, bool) or not isinstance(index, int | np.integer) or index < 0:
        raise InvalidInput(f"index must be an integer >= 0, got {index!r}")
    return np.random.SeedSequence(int(seed), spawn_key=(int(index),))


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or repr(exc)
    line = f"{type(exc).__name__}: {text}"
    return line if len(line) <= MAX_ERROR_CHARS else line[: MAX_ERROR_CHARS - 3] + "..."


def _run_item(fn: Callable[[Any], Any], item: Any) -> tuple[Any, str | None, float, float]:
    """``fn(item)`` in a worker: (value, error line, wall [s], CPU [s])."""
    from threadpoolctl import threadpool_limits

    t0, c0 = time.perf_counter(), time.process_time()
    try:
        # One BLAS thread everywhere: a multi-threaded BLAS sums in another order
        # (results differ in the last bits), and Ray's workers run single-threaded.
        with threadpool_limits(limits=1):
            value, error = fn(item), None
    except Exception as exc:  # an item's failure is data: report it, run the rest
        value, error = None, _one_line(exc)
    return value, error, time.perf_counter() - t0, time.process_time() - c0


Report = Callable[[int, tuple[Any, str | None, float, float]], None]
Result = tuple[Any, str | None, float, float]
CHUNKS_PER_SLOT = 4  # Ray tasks per parallel slot: few enough to amortise, enough to balance

_worker_fn: Callable[[Any], Any] | None = None  # a pool worker's fn, set once per process


def _set_worker_fn(fn: Callable[[Any], Any]) -> None:  # pragma: no cover - in the worker
    """Worker start: keep ``fn``; leave a terminal's Ctrl-C to the parent.

    SIGINT reaches every process of the foreground group: the workers ignore it (no
    KeyboardInterrupt traceback from each), and the parent stops them (:func:`_pool_pass`).
    """
    global _worker_fn
    _worker_fn = fn
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run_in_worker(item: Any) -> Result:  # pragma: no cover - in the worker
    assert _worker_fn is not None
    return _run_item(_worker_fn, item)


def _run_chunk(fn: Callable[[Any], Any], chunk: list[Any]) -> list[Result]:
    """Several items in one task (on Ray: one scheduling round trip for all of them)."""
    return [_run_item(fn, item) for item in chunk]


def _map_inline(fn: Callable[[Any], Any], items: Sequence[Any], report: Report) -> None:
    for i, item in enumerate(items):
        report(i, _run_item(fn, item))


def _map_pool(fn: Callable[[Any], Any], items: Sequence[Any], workers: int, report: Report) -> None:
    lost = _pool_pass(fn, items, range(len(items)), workers, report)
    # A worker that died (segfault, os._exit, out of memory) breaks the whole pool and
    # every unfinished item with it; rerun those one process each, so only the item
    # that kills its process is reported failed.
    for i in lost:
        if _pool_pass(fn, items, [i], 1, report):
            report(i, (None, "WorkerDied: the worker process exited while running this item",
                       0.0, 0.0))  # fmt: skip


def _pool_pass(
    fn: Callable[[Any], Any],
    items: Sequence[Any],
    indices: Sequence[int],
    workers: int,
    report: Report,
) -> list[int]:
    """Run ``indices`` in one pool; return those lost to a broken pool."""
    from concurrent.futures.process import BrokenProcessPool

    lost: list[int] = []
    # Workers come from a fork server (a clean process), not from forking this one:
    # a process that has already run MediaPipe or opened a GL context cannot be
    # forked safely (its children crash), and the items must not inherit its state.
    # ``fn`` (with the inputs all items share) goes to each worker once, not per item.
    ctx = multiprocessing.get_context("forkserver")
    _preload(ctx, fn)
    claim()  # the fork server it starts is stopped before this process exits
    with ProcessPoolExecutor(
        max_workers=min(workers, len(indices)), mp_context=ctx,
        initializer=_set_worker_fn, initargs=(fn,),
    ) as pool:  # fmt: skip
        futures: dict[Future[Any], int] = {}
        try:  # a stop while the workers start (submit spawns them) waits until they are known
            with deferred():
                for i in indices:
                    futures[pool.submit(_run_in_worker, items[i])] = i
            pending = set(futures)
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in sorted(done, key=futures.__getitem__):
                    i = futures[fut]
                    try:
                        report(i, fut.result())
                    except BrokenProcessPool:
                        lost.append(i)
                    except Exception as exc:  # e.g. a value that cannot be pickled back
                        report(i, (None, _one_line(exc), 0.0, 0.0))
        except BaseException:
            # Ctrl-C or an error: the running items are abandoned, their workers stopped
            # now (leaving the block would otherwise wait for each item to finish)
            procs = list((getattr(pool, "_processes", None) or {}).values())
            pool.shutdown(wait=False, cancel_futures=True)
            for proc in procs:
                proc.terminate()
            for proc in procs:  # gone before this process exits (none reads a freed queue)
                proc.join()
            raise
    return sorted(lost)


def _preload(ctx: Any, fn: Callable[[Any], Any]) -> None:
    """Have the fork server import ``fn``'s module once, so its workers start with it loaded.

    Takes effect when this process starts its fork server (the first pool). Importing
    runs no tracker or renderer, so forking after it is safe.
    """
    module = getattr(getattr(fn, "func", fn), "__module__", None)
    if module and module.startswith("dexlfd."):
        ctx.set_forkserver_preload(["__main__", module])


def _import_ray() -> Any:
    from dexlfd._extras import import_extra

    return import_extra("ray", "the Ray engine (--engine ray)")


# The Ray session this process started: {"cpus": int, "address": str or None, "temp_dir": str
# or None}. It is kept for later calls (starting a cluster costs seconds; its workers keep
# dexlfd imported) and shut down by shutdown_ray() or at exit.
_own_ray: dict[str, Any] = {}
_atexit_registered: list[bool] = []


def shutdown_ray() -> None:
    """Stop the Ray session :func:`map_items` started (its local cluster or connection).

    Its session folder is removed; a no-op when :func:`map_items` started none.
    """
    if not _own_ray:
        return
    ray = _import_ray()
    ray.shutdown()
    if _own_ray.get("temp_dir"):
        shutil.rmtree(_own_ray["temp_dir"], ignore_errors=True)
    _own_ray.clear()


# how long a cluster's head may take to accept a connection before it counts as unreachable
PROBE_TIMEOUT_S = 5.0


def _probe_address(address: str, timeout_s: float = PROBE_TIMEOUT_S) -> None:
    """Refuse, within ``timeout_s``, a ``host:port`` (or ``ray://host:port``) nobody answers at.

    Ray itself waits minutes for a closed port before it gives up; a plain TCP connection
    to the head's port says at once (refused) or within ``timeout_s`` (unroutable).
    ``"auto"`` and other forms without a port are left to Ray.
    """
    import socket

    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not port.isdigit() or not host:
        return
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s):
            pass
    except OSError as exc:
        reason = "timed out" if isinstance(exc, TimeoutError) else (exc.strerror or str(exc))
        raise InvalidInput(
            f"cannot reach the cluster at address {address!r}: {reason} "
            f"(nothing accepted a connection at {host}:{port} within {timeout_s:g} s)"
        ) from None


def _ray_session(
    workers: int, address: str | None, temp_dir: str | os.PathLike[str] | None
) -> tuple[Any, int]:
    """The Ray module, connected, and how many items may run at once."""
    ray = _import_ray()
    if ray.is_initialized():
        if not _own_ray:
            logger.info("using this process's Ray connection (workers/address ignored)")
            return ray, max(1, int(ray.cluster_resources().get("CPU", 1)))
        if address and _own_ray["address"] == address:
            return ray, max(1, int(ray.cluster_resources().get("CPU", 1)))
        if not address and not _own_ray["address"] and _own_ray["cpus"] >= workers:
            return ray, workers  # our running local cluster, its workers warm
    shutdown_ray()  # ours but too small, another address, or gone: stop it, remove its files
    kwargs: dict[str, Any] = {"logging_level": logging.WARNING, "log_to_driver": False}
    own_tmp = None
    if address:
        _probe_address(address)
        kwargs["address"] = address
    else:
        if temp_dir is None:
            # outside any repository; removed at shutdown
            temp_dir = own_tmp = tempfile.mkdtemp(prefix="dexlfd-ray-")
        kwargs.update(num_cpus=workers, include_dashboard=False, _temp_dir=str(temp_dir))
    try:
        ray.init(**kwargs)
    except Exception as exc:
        if own_tmp is not None:
            shutil.rmtree(own_tmp, ignore_errors=True)
        where = f"the cluster at address {address!r}" if address else "a local Ray cluster"
        raise InvalidInput(f"cannot start or reach {where}: {_one_line(exc)}") from exc
    if not _atexit_registered:
        atexit.register(shutdown_ray)
        _atexit_registered.append(True)
    _own_ray.update(cpus=workers, address=address, temp_dir=own_tmp)
    logger.info("Ray: %s", ray.cluster_resources())
    slots = workers if not address else int(ray.cluster_resources().get("CPU", 1))
    return ray, max(1, slots)


def _map_ray(
    fn: Callable[[Any], Any],
    items: Sequence[Any],
    workers: int,
    address: str | None,
    temp_dir: str | os.PathLike[str] | None,
    report: Report,
) -> None:
    ray, slots = _ray_session(workers, address, temp_dir)
    task = ray.remote(num_cpus=1, max_retries=1)(_run_chunk)
    fn_ref = ray.put(fn)  # shipped once (with the inputs every item shares), not per item
    size = max(1, len(items) // (slots * CHUNKS_PER_SLOT))
    queue = [list(range(i, min(i + size, len(items)))) for i in range(0, len(items), size)]
    running: dict[Any, list[int]] = {}
    while queue or running:
        while queue and len(running) < slots:  # at most `workers` items at once
            chunk = queue.pop(0)
            running[task.remote(fn_ref, [items[i] for i in chunk])] = chunk
        done, _ = ray.wait(list(running), num_returns=1)
        chunk = running.pop(done[0])
        try:
            results = ray.get(done[0])
        except ray.exceptions.RayError as exc:  # the worker died, or was lost
            if len(chunk) > 1:  # rerun one by one: only the item that kills it fails
                queue[:0] = [[i] for i in chunk]
                continue
            results = [(None, _one_line(exc), 0.0, 0.0)]
        for i, result in zip(chunk, results, strict=True):
            report(i, result)


class _Progress:
    """Outcomes as they arrive, a progress bar and the caller's callback."""

    def __init__(
        self,
        labels: list[str],
        desc: str,
        quiet: bool,
        callback: Callable[[int, float], None] | None,
    ) -> None:
        from tqdm import tqdm

        self.labels, self.callback = labels, callback
        self.outcomes: list[ItemOutcome | None] = [None] * len(labels)
        self.bar = tqdm(
            total=len(labels), desc=desc or None, file=sys.stderr, leave=False,
            disable=quiet or not sys.stderr.isatty(),
        )  # fmt: skip

    def report(self, i: int, result: Result) -> None:
        value, error, seconds, cpu = result
        self.outcomes[i] = ItemOutcome(i, self.labels[i], value, error, seconds, cpu)
        if error is not None:
            logger.debug("%s failed: %s", self.labels[i], error)
            failed = sum(o is not None and not o.ok for o in self.outcomes)
            self.bar.set_postfix_str(f"{failed} failed")
        self.bar.update(1)
        if self.callback is not None:
            self.callback(i, seconds)


def _check_arguments(
    engine: str, workers: int, labels: Sequence[str], items: Sequence[Any]
) -> None:
    if engine not in ENGINES:
        raise InvalidInput(f"engine must be one of {ENGINES}, got {engine!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InvalidInput(f"workers must be an integer >= 1, got {workers!r}")
    if len(labels) != len(items):
        raise InvalidInput(f"labels must have one entry per item ({len(items)}), got {len(labels)}")


def map_items(
    fn: Callable[[Any], Any],
    items: Sequence[Any],
    *,
    labels: Sequence[str],
    engine: str = "local",
    workers: int = 1,
    address: str | None = None,
    desc: str = "",
    quiet: bool = False,
    callback: Callable[[int, float], None] | None = None,
    temp_dir: str | os.PathLike[str] | None = None,
) -> list[ItemOutcome]:
    """Compute ``fn(item)`` for every item on ``engine``; outcomes in input order.

    Parameters
    ----------
    fn : callable
        A picklable function of one item (a module-level function, or a
        :func:`functools.partial` of one); its return value must be picklable.
        Inputs every item shares belong in ``fn`` (a partial): they are sent to
        each worker once, not with every item.
    items : sequence
        The inputs; each must be picklable.
    labels : sequence of str
        One name per item, used in the progress bar's failure report.
    engine : {"local", "ray"}
        Where to run (see the module docstring).
    workers : int
        Processes (local), or the local Ray cluster's CPUs and items at once,
        >= 1; ignored when using a Ray connection this process already had.
    address : str, optional
        A running Ray cluster (``"host:6379"``, ``"ray://host:10001"`` or
        ``"auto"``); its nodes must have the same dexlfd installed.
    desc : str
        Progress bar title. The bar (tqdm, stderr) advances as items finish;
        it is off when ``quiet`` or when stderr is not a terminal.
    callback : callable, optional
        ``callback(index, seconds)`` after each finished item.
    temp_dir : path-like, optional
        Session folder of a local Ray cluster started here (default: a new
        temporary folder, removed at shutdown).

    Returns
    -------
    list of ItemOutcome
        ``outcomes[i]`` belongs to ``items[i]``.

    Raises
    ------
    InvalidInput
        Unknown engine, ``workers < 1``, labels and items of different
        lengths, or a Ray cluster that cannot be started or reached.
    DependencyNotInstalled
        ``engine="ray"`` without the ``ray`` package.
    """
    _check_arguments(engine, workers, labels, items)
    if not items:
        return []
    progress = _Progress([str(lab) for lab in labels], desc, quiet, callback)
    t0 = time.perf_counter()
    with progress.bar:
        if engine == "ray":
            _map_ray(fn, items, workers, address, temp_dir, progress.report)
        elif workers == 1 or len(items) == 1:
            _map_inline(fn, items, progress.report)
        else:
            _map_pool(fn, items, workers, progress.report)
    done = [o for o in progress.outcomes if o is not None]
    if len(done) != len(items):  # every path reports every item; guard the contract
        raise RuntimeError(f"engine {engine!r} returned {len(done)} of {len(items)} outcomes")
    logger.info("%s: %d items on %s (%d workers) in %.1f s", desc or "map_items", len(done),
                engine, workers, time.perf_counter() - t0)  # fmt: skip
    failures = format_failures(done)
    if failures:
        logger.warning("%s", failures)
    return done


def format_failures(outcomes: Sequence[ItemOutcome]) -> str:
    """A summary of the failed items (``""`` when none failed), one line per item."""
    failed = [o for o in outcomes if not o.ok]
    if not failed:
        return ""
    lines = [f"{len(failed)} of {len(outcomes)} items failed:"]
    lines += [f"  {o.label}: {o.error}" for o in failed]
    return "\n".join(lines)
