"""A video's next frames decoded on a worker thread while this one is tracked.

Decoding a 1080p frame (and its BGR -> RGB copy) takes a few milliseconds that the
hand tracker's own wait can cover: :func:`prefetched` runs a frame iterator on a
worker thread, at most ``depth`` frames ahead, and yields the same frames in the same
order. An error of the iterator is raised where the frame would have been; stopping
early (an error or an interrupt in the consumer) stops the worker and closes the
iterator before returning.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterator
from typing import TypeVar

__all__ = ["prefetched"]

T = TypeVar("T")
_POLL_S = 0.1  # how often a blocked worker looks whether the consumer stopped [s]


def prefetched(items: Iterator[T], depth: int = 2) -> Iterator[T]:
    """``items`` read on a worker thread, at most ``depth`` ahead; the same items in order."""
    box: queue.Queue[tuple[str, object]] = queue.Queue(maxsize=max(1, depth))
    stop = threading.Event()

    def hand_over(item: tuple[str, object]) -> bool:
        while not stop.is_set():
            try:
                box.put(item, timeout=_POLL_S)
                return True
            except queue.Full:
                continue
        return False

    def work() -> None:
        last: tuple[str, object] = ("end", None)
        try:
            for item in items:
                if not hand_over(("item", item)):
                    return
        except BaseException as exc:  # handed to the consumer, raised there
            last = ("error", exc)
        finally:
            close = getattr(items, "close", None)
            try:
                if close is not None:
                    close()
            except BaseException as exc:  # the consumer must hear of it, not wait forever
                if last[0] != "error":
                    last = ("error", exc)
        hand_over(last)

    worker = threading.Thread(target=work, name="dexlfd-prefetch", daemon=True)
    worker.start()
    try:
        while True:
            kind, value = box.get()
            if kind == "item":
                yield value  # type: ignore[misc]
            elif kind == "error":
                assert isinstance(value, BaseException)
                raise value
            else:
                return
    finally:
        stop.set()
        worker.join()
