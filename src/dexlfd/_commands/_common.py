"""Helpers shared by subcommands: output folders, progress bars, seeds."""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

__all__ = [
    "MAX_SEED",
    "bounded_float",
    "bounded_int",
    "ensure_output_dir",
    "nonnegative_int",
    "output_file",
    "phase_progress",
    "positive_int",
    "progress",
    "seed",
]

MAX_SEED = 2**32 - 1  # seeds are recorded in files' meta; numpy takes any, JSON readers not


def ensure_output_dir(path: str | os.PathLike[str], arg: str = "-o/--output") -> Path:
    """Create the folder ``path`` (and parents) and check it is writable; name ``arg``.

    The output policy of :mod:`dexlfd._commands._outputs` for one folder.
    """
    from dexlfd._commands._outputs import DIR, check_outputs

    check_outputs([(arg, path, DIR)])
    return Path(path)


def output_file(path: str | os.PathLike[str], arg: str, suffix: str | None = None) -> Path:
    """Check an output file can be created (its folder exists and is writable).

    With ``suffix`` (e.g. ``".mp4"``) the name must end in it: the file is written
    in that format whatever its name says, so a ``.avi`` name would mislead. The output
    policy of :mod:`dexlfd._commands._outputs` for one file without inputs; commands
    with inputs call :func:`~dexlfd._commands._outputs.check_outputs`.
    """
    from dexlfd._commands._outputs import check_outputs

    check_outputs([(arg, path, suffix)])
    return Path(path)


def nonnegative_int(text: str) -> int:
    """Argparse type: an integer >= 0 (seeds, counts)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {value}")
    return value


def positive_int(text: str) -> int:
    """Argparse type: an integer > 0 (sizes in pixels, frame counts)."""
    value = nonnegative_int(text)
    if value == 0:
        raise argparse.ArgumentTypeError("expected an integer > 0, got 0")
    return value


def _in_range(
    convert: Callable[[str], Any], noun: str, accepted: str, inside: Callable[[Any], bool]
) -> Callable[[str], Any]:
    """Argparse type: ``convert(text)`` that ``inside`` accepts; errors give ``accepted``.

    ``noun`` is "an integer" or "a number"; argparse's "invalid <name> value" uses its
    last word. A number out of range is shown as typed, an integer as parsed.
    """

    def parse(text: str) -> Any:
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected {noun} in {accepted}, got {text!r}"
            ) from None
        if not inside(value):  # NaN is never inside
            shown = text if convert is float else value
            raise argparse.ArgumentTypeError(f"expected {noun} in {accepted}, got {shown}")
        return value

    parse.__name__ = noun.split()[-1]
    return parse


def bounded_int(lo: int, hi: int) -> Callable[[str], int]:
    """Argparse type: an integer in ``[lo, hi]``; the message gives the accepted range."""
    return _in_range(int, "an integer", f"{lo}..{hi}", lambda v: lo <= v <= hi)


def bounded_float(
    lo: float, hi: float, *, lo_open: bool = False, unit: str = ""
) -> Callable[[str], float]:
    """Argparse type: a finite number in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""
    unit = f" {unit}" if unit else ""
    accepted = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]{unit}"
    return _in_range(
        float, "a number", accepted, lambda v: (lo < v if lo_open else lo <= v) and v <= hi
    )


def seed(text: str) -> int:
    """Argparse type: a random seed, an integer in ``0..MAX_SEED``."""
    return bounded_int(0, MAX_SEED)(text)


def progress(
    total: int | None, desc: str, *, quiet: bool = False, bar_format: str | None = None
) -> Any:
    """A tqdm bar on stderr, disabled when stderr is not a terminal or ``quiet``."""
    from tqdm import tqdm

    return tqdm(
        total=total, desc=desc, disable=quiet or not sys.stderr.isatty(), leave=False,
        bar_format=bar_format,
    )  # fmt: skip


@contextlib.contextmanager
def phase_progress(
    phases: Sequence[str], desc: str, *, quiet: bool = False
) -> Iterator[Callable[[str], None]]:
    """A :func:`progress` bar over named phases: ``step(name)`` starts the next one.

    The bar counts the phases finished and shows the running one's name; a phase
    not in ``phases`` is refused (the total would lie), and leaving the block
    finishes the last.
    """
    done: list[str] = []
    # phases of unequal length: the elapsed time, no rate or estimate
    fmt = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]"
    with progress(len(phases), desc, quiet=quiet, bar_format=fmt) as bar:

        def step(name: str) -> None:
            if name not in phases:
                raise ValueError(f"phase {name!r} is not one of {list(phases)}")
            if done:
                bar.update(1)
            done.append(name)
            bar.set_postfix_str(name, refresh=True)

        yield step
        if done:
            bar.update(1)


def rough_duration(seconds: float) -> str:
    """``seconds`` as a rough human duration (``40 s``, ``12 min``, ``3.5 h``), for estimates."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def tick_callback(bar: Any) -> Callable[[int, float], None]:
    """Adapt a tqdm bar to the library's ``callback(i, value)`` convention."""

    def _cb(i: int, value: float) -> None:
        bar.update(1)

    return _cb
