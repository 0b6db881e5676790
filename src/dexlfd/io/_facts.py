"""Typed facts of the file contracts: what one stage decides and a later stage reads.

A *fact* is a frozen dataclass deriving from :class:`Fact` (a grasp event, a plan's
obstacles, a placement verdict...). Its fields are annotated with plain types, and a
field's unit is stated once, in its metadata (``field(metadata={"unit": "m"})``).
A record of the file contracts (:class:`~dexlfd.io._record.Record`) names its fact
fields in ``FACTS``; they are written to the file's ``facts`` member as JSON and, on
load, converted back field by field by :func:`from_json`, which checks every value
against its annotation: a wrong type, a non-finite number or an unknown entry is one
:class:`~dexlfd.errors.InvalidFile` line naming the file and the entry's path
(``plan.npz: facts.obstacles[1].size_m[2] must be a finite number, got 'x'``).

Supported annotations: ``float`` (finite; an ``int`` is accepted), ``int``, ``bool``,
``str``, ``Literal[...]``, ``X | None``, ``tuple[T, ...]``, ``tuple[T1, T2, ...]``,
``dict[str, T]`` and nested :class:`Fact` subclasses. Tuples, not lists, keep facts
hashable and frozen. ``meta`` keeps only provenance and free text.
"""

from __future__ import annotations

import dataclasses
import json
import math
import types
import typing
from typing import Any, ClassVar, Literal, TypeVar, Union

from dexlfd.errors import InvalidFile

__all__ = ["Fact", "facts_member", "from_json", "to_json", "unit_of"]

F = TypeVar("F", bound="Fact")


class Fact:
    """Mixin of the typed facts: ``@dataclass(frozen=True)`` subclasses.

    ``to_json()`` gives the JSON value written to a file; ``from_json(obj, where)``
    reads one back, checked against the annotations (see the module docstring).
    """

    __dataclass_fields__: ClassVar[dict[str, Any]]

    def to_json(self) -> dict[str, Any]:
        """The fact as a JSON object (tuples become lists, nested facts objects)."""
        return typing.cast(dict[str, Any], to_json(self))

    @classmethod
    def from_json(cls: type[F], obj: Any, where: str) -> F:
        """A ``cls`` read from the JSON value ``obj``; ``where`` names it in errors."""
        return typing.cast(F, from_json(cls, obj, where))


def facts_member(arrays: dict[str, Any], where: str) -> dict[str, Any]:
    """The JSON object of a loaded file's ``facts`` member, popped from ``arrays``.

    ``{}`` when the file has none; :class:`InvalidFile` naming ``where`` when it is
    not a JSON object.
    """
    if "facts" not in arrays:
        return {}
    try:
        raw = json.loads(str(arrays.pop("facts")))
    except (ValueError, TypeError, RecursionError) as exc:
        raise InvalidFile(f"{where}: unreadable 'facts': {exc}") from exc
    if not isinstance(raw, dict):
        raise InvalidFile(f"{where}: 'facts' must be a JSON object")
    return raw


def unit_of(cls: type[Fact], name: str) -> str:
    """The unit of field ``name`` of the fact ``cls`` (``""`` when unitless)."""
    return str(cls.__dataclass_fields__[name].metadata.get("unit", ""))


def to_json(value: Any) -> Any:
    """``value`` (a fact, a tuple/list/dict of them, or a plain value) as JSON."""
    if isinstance(value, Fact):
        return {f.name: to_json(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, tuple | list):
        return [to_json(v) for v in value]
    if isinstance(value, dict):
        return {str(k): to_json(v) for k, v in value.items()}
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"a fact holds the non-finite number {value}")
    if hasattr(value, "item") and callable(value.item):  # a numpy scalar
        return to_json(value.item())
    return value


_HINTS: dict[type, dict[str, Any]] = {}


def _hints(cls: type) -> dict[str, Any]:
    if cls not in _HINTS:
        _HINTS[cls] = typing.get_type_hints(cls)
    return _HINTS[cls]


def from_json(hint: Any, obj: Any, where: str) -> Any:
    """``obj`` converted to the annotation ``hint``, or :class:`InvalidFile` naming ``where``."""
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if isinstance(hint, type) and issubclass(hint, Fact):
        return _fact(hint, obj, where)
    if origin in (Union, types.UnionType):
        if obj is None and type(None) in args:
            return None
        options = [a for a in args if a is not type(None)]
        if len(options) == 1:
            return from_json(options[0], obj, where)
        for option in options:  # e.g. str | float: the first that takes the value
            try:
                return from_json(option, obj, where)
            except InvalidFile:
                continue
        _fail(where, " or ".join(_name(a) for a in options), obj)
    if origin is Literal:
        if obj not in args or isinstance(obj, bool) != any(isinstance(a, bool) for a in args):
            _fail(where, "one of " + ", ".join(repr(a) for a in args), obj)
        return obj
    if origin is tuple:
        if not isinstance(obj, list | tuple):
            _fail(where, "a list", obj)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(from_json(args[0], v, f"{where}[{i}]") for i, v in enumerate(obj))
        if len(obj) != len(args):
            _fail(where, f"a list of {len(args)} entries", obj)
        pairs = enumerate(zip(args, obj, strict=True))
        return tuple(from_json(a, v, f"{where}[{i}]") for i, (a, v) in pairs)
    if origin is dict:
        if not isinstance(obj, dict):
            _fail(where, "a JSON object", obj)
        return {str(k): from_json(args[1], v, f"{where}.{k}") for k, v in obj.items()}
    return _scalar(hint, obj, where)


def _fact(cls: type[Fact], obj: Any, where: str) -> Fact:
    if not isinstance(obj, dict):
        _fail(where, "a JSON object", obj)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(obj) - set(fields))
    if unknown:
        raise InvalidFile(f"{where}: unknown entry {unknown[0]!r} (expected {', '.join(fields)})")
    hints = _hints(cls)
    kwargs = {}
    for name, f in fields.items():
        if name in obj:
            kwargs[name] = from_json(hints[name], obj[name], f"{where}.{name}")
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            raise InvalidFile(f"{where}: missing entry {name!r}")
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:  # the fact's own __post_init__ checks
        raise InvalidFile(f"{where}: {exc}") from exc


def _scalar(hint: Any, obj: Any, where: str) -> Any:
    if hint is float:
        if isinstance(obj, bool) or not isinstance(obj, int | float) or not math.isfinite(obj):
            _fail(where, "a finite number", obj)
        return float(obj)
    if hint is int:
        if isinstance(obj, bool) or not isinstance(obj, int):
            _fail(where, "an integer", obj)
        return obj
    if hint is bool:
        if not isinstance(obj, bool):
            _fail(where, "true or false", obj)
        return obj
    if hint is str:
        if not isinstance(obj, str):
            _fail(where, "a string", obj)
        return obj
    if hint is Any:
        return obj
    raise TypeError(f"{where}: unsupported fact annotation {hint!r}")


def _name(hint: Any) -> str:
    return getattr(hint, "__name__", str(hint))


def _fail(where: str, expected: str, obj: Any) -> typing.NoReturn:
    raise InvalidFile(f"{where} must be {expected}, got {str(obj)[:40]!r}")
