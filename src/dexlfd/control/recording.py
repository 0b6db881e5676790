"""Per-tick samples of a 1 kHz loop, in preallocated arrays (no allocation per tick)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["Recording"]


class Recording:
    """Named per-tick arrays that grow by doubling.

    Parameters
    ----------
    fields : dict
        ``name -> (shape of one sample, dtype)``.
    capacity : int
        Samples preallocated (grown when :meth:`ensure` asks for more).

    Attributes
    ----------
    a : dict of ndarray
        ``name -> array (capacity, *shape)``; the loop writes row ``k`` in place.
    """

    def __init__(self, fields: dict[str, tuple[tuple[int, ...], Any]], capacity: int) -> None:
        self.a = {k: np.zeros((capacity, *s), dtype=d) for k, (s, d) in fields.items()}

    def ensure(self, k: int) -> None:
        """Make room for row ``k``."""
        cap = next(iter(self.a.values())).shape[0]
        if k < cap:
            return
        new = max(2 * cap, k + 1)
        for key, arr in self.a.items():
            grown = np.zeros((new, *arr.shape[1:]), dtype=arr.dtype)
            grown[:cap] = arr
            self.a[key] = grown

    def first(self, n: int, *, copy: bool = False) -> dict[str, np.ndarray]:
        """The first ``n`` rows of every field (views, or copies with ``copy``)."""
        return {k: (arr[:n].copy() if copy else arr[:n]) for k, arr in self.a.items()}
