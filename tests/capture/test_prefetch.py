"""Prefetching a video's frames changes nothing but when they are decoded."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from dexlfd.capture.prefetch import prefetched


def test_the_same_items_in_the_same_order() -> None:
    assert list(prefetched(iter(range(50)), depth=2)) == list(range(50))
    assert list(prefetched(iter([]))) == []


def test_an_error_of_the_source_is_raised_after_the_items_before_it() -> None:
    def broken() -> Iterator[int]:
        yield 1
        yield 2
        raise OSError("corrupt frame")

    assert _read_until_error(broken(), "corrupt frame") == [1, 2]


def test_stopping_early_stops_the_worker_and_closes_the_source() -> None:
    closed = threading.Event()

    def endless() -> Iterator[int]:
        try:
            i = 0
            while True:
                yield i
                i += 1
        finally:
            closed.set()

    before = threading.active_count()
    it = prefetched(endless(), depth=2)
    assert [next(it) for _ in range(5)] == [0, 1, 2, 3, 4]
    it.close()
    assert closed.is_set()  # closed by the worker before close() returned
    assert threading.active_count() == before


def test_a_source_whose_close_fails_is_heard_of_not_waited_for() -> None:
    class Unclosable:
        def __init__(self) -> None:
            self.items = iter([1, 2])

        def __iter__(self) -> Unclosable:
            return self

        def __next__(self) -> int:
            return next(self.items)

        def close(self) -> None:
            raise OSError("device busy")

    assert _read_until_error(Unclosable(), "device busy") == [1, 2]


def _read_until_error(items: Iterator[int], match: str) -> list[int]:
    """The items ``prefetched`` gives before it raises the ``OSError`` matching ``match``."""
    got = []
    with pytest.raises(OSError, match=match):
        for x in prefetched(items):
            got.append(x)
    return got
