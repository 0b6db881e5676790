"""Input checks used once at public boundaries.

Each helper converts its input, checks it and returns the converted array; the
error names the argument, what was expected and what was given.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput

__all__ = [
    "as_float_array",
    "check_finite",
    "check_positive",
    "check_time",
    "check_trajectory",
]


def as_float_array(
    value: Any, name: str, *, ndim: int | None = None, shape: tuple[int | None, ...] | None = None
) -> FloatArray:
    """Convert to a float64 array and check its rank or shape.

    ``shape`` entries that are ``None`` accept any length on that axis.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{name} must be numeric, got {type(value).__name__}") from exc
    if ndim is not None and arr.ndim != ndim:
        raise InvalidInput(f"{name} must have {ndim} dimensions, got shape {arr.shape}")
    if shape is not None and (
        arr.ndim != len(shape)
        or any(s is not None and s != a for s, a in zip(shape, arr.shape, strict=True))
    ):
        expected = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise InvalidInput(f"{name} must have shape {expected}, got {arr.shape}")
    return arr


def check_finite(arr: FloatArray, name: str) -> FloatArray:
    """Raise if ``arr`` contains NaN or inf, naming the first bad index."""
    if np.isfinite(arr).all():  # the common case: one pass, no mask kept
        return arr
    bad = ~np.isfinite(arr)
    first = tuple(int(i) for i in np.argwhere(bad)[0])
    raise InvalidInput(
        f"{name} must be finite, found {int(bad.sum())} NaN/inf value(s), first at index {first}"
    )


def check_positive(value: float, name: str, *, strict: bool = True) -> float:
    """Check a scalar is finite and > 0 (or >= 0 when ``strict`` is false)."""
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{name} must be a number, got {value!r}") from exc
    if not np.isfinite(v) or (v <= 0 if strict else v < 0):
        raise InvalidInput(f"{name} must be {'>' if strict else '>='} 0, got {value!r}")
    return v


def check_time(t: Any, name: str = "t", *, min_len: int = 2) -> FloatArray:
    """Check a time vector: 1-D, finite, strictly increasing, ``min_len`` samples."""
    arr = check_finite(as_float_array(t, name, ndim=1), name)
    if arr.shape[0] < min_len:
        raise InvalidInput(f"{name} must have at least {min_len} samples, got {arr.shape[0]}")
    steps = np.diff(arr)
    if (steps <= 0).any():
        i = int(np.argmax(steps <= 0))
        raise InvalidInput(
            f"{name} must be strictly increasing, but {name}[{i + 1}]={arr[i + 1]!r} "
            f"<= {name}[{i}]={arr[i]!r}"
        )
    return arr


def check_trajectory(
    t: Any,
    x: Any,
    *,
    t_name: str = "t",
    x_name: str = "x",
    n_dims: int | None = None,
    min_len: int = 2,
    allow_nan: bool = False,
) -> tuple[FloatArray, FloatArray]:
    """Check a time series ``(t, x)``: ``t`` (n,), ``x`` (n, d), finite unless allowed."""
    t_arr = check_time(t, t_name, min_len=min_len)
    x_arr = as_float_array(x, x_name)
    if x_arr.ndim == 1:
        x_arr = x_arr[:, None]
    expected_d = "d" if n_dims is None else str(n_dims)
    if (
        x_arr.ndim != 2
        or x_arr.shape[0] != t_arr.shape[0]
        or (n_dims is not None and x_arr.shape[1] != n_dims)
    ):
        raise InvalidInput(
            f"{x_name} must have shape ({t_arr.shape[0]}, {expected_d}) to match "
            f"{t_name}, got {x_arr.shape}"
        )
    if allow_nan:
        if np.isinf(x_arr).any():
            raise InvalidInput(f"{x_name} must not contain inf")
    else:
        check_finite(x_arr, x_name)
    return t_arr, x_arr
