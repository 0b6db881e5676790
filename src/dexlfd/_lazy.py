"""A package whose names are imported on first use (PEP 562 ``__getattr__``).

``dexlfd.plan`` and ``dexlfd.learn`` pull in numba and SciPy; a command that only reads
their settings (``--help``, ``teach`` before its record stage) should not wait for them.
A package calls :func:`lazy_package` with a map *name -> module it comes from* and binds
the two functions it returns as its module-level ``__getattr__`` and ``__dir__``.

A name that is both a function and a submodule (``dexlfd.learn.dtw``, ``dexlfd.plan.forcing``)
stays the function, as with an eager ``from .dtw import dtw``: importing the submodule later
sets the package's attribute to the module, which :class:`_LazyPackage` refuses so that the
next lookup resolves the name again.
"""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_package"]


class _LazyPackage(types.ModuleType):
    """A package module that keeps its exported functions over same-named submodules."""

    def __setattr__(self, name: str, value: Any) -> None:
        exports: Mapping[str, str] = self.__dict__.get("_lazy_exports", {})
        if name in exports and isinstance(value, types.ModuleType):
            self.__dict__.pop(name, None)  # resolved again by __getattr__: the function
            return
        super().__setattr__(name, value)


def lazy_package(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package``, whose ``exports`` map names to modules."""
    module = sys.modules[package]
    module.__dict__["_lazy_exports"] = exports
    module.__class__ = _LazyPackage
    namespace = module.__dict__

    def getattr_(name: str) -> Any:
        source = exports.get(name)
        if source is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(source), name)
        namespace[name] = value
        return value

    def dir_() -> list[str]:
        return sorted({*namespace, *exports})

    return getattr_, dir_
