"""Typed facts moved onto a part's own clock: times shifted, spans cut to the part.

A fact field on its record's clock says so in its metadata (:mod:`dexlfd.io._facts`):
``clock="at"`` an instant [s], ``clock="span"`` an interval ``(a, b)`` [s] or a tuple
of them. A field that pairs with such a tuple, entry by entry, names it with
``per="field"``. Durations (``added_s``, ``hold_s`` of a grasp schedule) are on no
clock and stay as they are.

:func:`on_part_clock` takes a fact (or a tuple of facts) of a record to the record's
stretch ``start..end`` [s on its clock] run on a clock of its own from 0: an instant
is shifted by ``-start`` (one outside the stretch keeps its place on the new clock,
before 0 or after its end); an interval is shifted and cut to ``0..end - start``, and
dropped, with what pairs with it, when it lies outside or only touches an end (a
grasp that closes at the part's last sample is the next part's). A fact in a tuple whose
own interval is dropped (a slow-down of another part) is dropped from the tuple.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from dexlfd.io._facts import Fact

__all__ = ["on_part_clock"]

_OUT = object()  # an interval wholly outside the stretch


def _span(v: tuple[float, float], start: float, length: float) -> Any:
    a, b = v[0] - start, v[1] - start
    inside = b > 0.0 and a < length if b > a else 0.0 <= a <= length
    if not inside:  # outside, or touching the stretch only at an end
        return _OUT
    return (max(a, 0.0), min(b, length))


def _field(value: Any, clock: str | None, start: float, length: float) -> Any:
    """One field's value on the new clock (``_OUT`` for an interval outside it)."""
    if value is None:
        return None
    if clock == "at":
        return float(value) - start
    if clock == "span":
        if not value or isinstance(value[0], tuple):  # a tuple of intervals
            return tuple(_span(v, start, length) for v in value)
        return _span(value, start, length)
    if isinstance(value, Fact):
        return on_part_clock(value, start, start + length)
    if isinstance(value, tuple) and value and isinstance(value[0], Fact):
        moved = (on_part_clock(v, start, start + length) for v in value)
        return tuple(v for v in moved if v is not None)
    return value


def on_part_clock(fact: Any, start: float, end: float) -> Any:
    """``fact`` on the clock of the stretch ``start..end`` [s] (module docstring).

    None for a fact whose own interval lies outside the stretch; a tuple of facts
    loses those.
    """
    if isinstance(fact, tuple):
        moved = (on_part_clock(v, start, end) for v in fact)
        return tuple(v for v in moved if v is not None)
    if not isinstance(fact, Fact):
        return fact
    length = end - start
    fields = dataclasses.fields(fact)
    out = {
        f.name: _field(getattr(fact, f.name), f.metadata.get("clock"), start, length)
        for f in fields
    }
    if any(v is _OUT for v in out.values()):
        return None  # the fact's own interval (a slow-down's) is not in the stretch
    for f in fields:
        value = out[f.name]
        if f.metadata.get("clock") == "span" and isinstance(value, tuple) and _OUT in value:
            keep = [k for k, v in enumerate(value) if v is not _OUT]
            out[f.name] = tuple(value[k] for k in keep)
            for g in fields:  # what pairs with it, entry by entry
                if g.metadata.get("per") == f.name:
                    out[g.name] = tuple(out[g.name][k] for k in keep)
    return dataclasses.replace(fact, **out)
