"""One statement per setting: name, unit, default, range and help of a config field.

A frozen config dataclass declares a setting with :func:`param` (a
:func:`dataclasses.field` whose metadata is a :class:`Param`); its ``__post_init__``
checks the range with :func:`check_params`, and the command line builds the flag, its
range check and its ``--help`` text from the same record
(:mod:`dexlfd._commands._fields`). Nothing else states the range again.

Examples
--------
>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Cfg:
...     margin: float = param(0.02, "clearance to keep", unit="m", lo=0.0, hi=1.0)
...     def __post_init__(self) -> None:
...         check_params(self)
>>> Cfg(margin=2.0)
Traceback (most recent call last):
...
dexlfd.errors.InvalidInput: Cfg.margin must be in [0, 1] m, got 2.0
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass
from typing import Any

from dexlfd.errors import InvalidInput

__all__ = ["Param", "check_params", "param", "params_of"]

# a unit as the end of a flag name: --payload-kg, --max-speed-mps, --rate-hz
FLAG_SUFFIX = {
    "m": "m",
    "kg": "kg",
    "s": "s",
    "Hz": "hz",
    "deg": "deg",
    "N": "n",
    "m/s": "mps",
    "rad/s": "radps",
    "px": "px",
    "ticks": "ticks",
}


@dataclass(frozen=True)
class Param:
    """How a config field is stated to a user.

    Attributes
    ----------
    help : str
        What the setting does, one phrase (the range and default are added).
    unit : str
        Its unit (``"m"``, ``"kg"``, ``"s"``, ``"Hz"``, ``"deg"``, ``"N"``, ``"m/s"``,
        ``"rad/s"``, ``"px"``, ``"ticks"``), ``""`` for a ratio or a count.
    lo, hi : float, optional
        Accepted range (None: unbounded on that side); ``lo_open``/``hi_open`` exclude
        the end.
    integer : bool
        The value is an integer (a count).
    flag : str, optional
        The command-line flag; default ``--<name>`` with ``_`` as ``-``, ending in the
        unit (``margin``, ``"m"`` -> ``--margin-m``).
    aliases : tuple of str
        Older spellings of the flag: still accepted, with a deprecation warning.
    words : tuple of str
        Words accepted besides a number (``"auto"``: the config chooses).
    """

    help: str
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False
    flag: str | None = None
    aliases: tuple[str, ...] = ()
    words: tuple[str, ...] = ()

    def flag_for(self, name: str) -> str:
        """The flag of the field ``name``: given, else built from the name and unit."""
        if self.flag is not None:
            return self.flag
        stem = name.replace("_", "-")
        suffix = FLAG_SUFFIX.get(self.unit, "")
        if suffix and not stem.endswith("-" + suffix):
            stem = f"{stem}-{suffix}"
        return "--" + stem

    def accepted(self) -> str:
        """The range as text: ``[0, 1] m``, ``1..50``, ``(0, inf) s``."""
        unit = f" {self.unit}" if self.unit else ""
        lo = "-inf" if self.lo is None else f"{self.lo:g}"
        hi = "inf" if self.hi is None else f"{self.hi:g}"
        if self.integer and self.lo is not None and self.hi is not None:
            return f"{lo}..{hi}{unit}" + "".join(f" or {w}" for w in self.words)
        left = "(" if self.lo_open or self.lo is None else "["
        right = ")" if self.hi_open or self.hi is None else "]"
        return f"{left}{lo}, {hi}{right}{unit}" + "".join(f" or {w}" for w in self.words)

    def inside(self, value: float) -> bool:
        """Whether ``value`` is finite (or an integer) within the range."""
        if not math.isfinite(value):
            return False
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        return not (self.hi is not None and (value >= self.hi if self.hi_open else value > self.hi))


def param(
    default: Any,
    help: str,  # noqa: A002 - the word every reader expects
    *,
    unit: str = "",
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    integer: bool = False,
    flag: str | None = None,
    aliases: tuple[str, ...] = (),
    words: tuple[str, ...] = (),
) -> Any:
    """A dataclass field with its :class:`Param` (``default`` may be None: not set)."""
    meta = Param(help, unit, lo, hi, lo_open, hi_open, integer, flag, aliases, words)
    return dataclasses.field(default=default, metadata={"param": meta})


def params_of(cls: Any) -> dict[str, Param]:
    """``{field name: Param}`` of a config class (fields declared with :func:`param`)."""
    return {f.name: f.metadata["param"] for f in dataclasses.fields(cls) if "param" in f.metadata}


def check_params(obj: Any) -> None:
    """Refuse a field of ``obj`` outside its :class:`Param` range, naming the field.

    None is accepted (the field is optional: the config chooses); a bool is not a number.
    """
    for name, meta in params_of(type(obj)).items():
        value = getattr(obj, name)
        if value is None or (meta.lo is None and meta.hi is None) or value in meta.words:
            continue
        ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
        if ok and meta.integer:
            ok = float(value).is_integer()
        if not ok or not meta.inside(float(value)):
            kind = "an integer " if meta.integer else ""
            raise InvalidInput(
                f"{type(obj).__name__}.{name} must be {kind}in {meta.accepted()}, got {value!r}",
                param=name,
            )
