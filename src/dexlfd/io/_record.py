"""Base class of the file-contract dataclasses (demonstration, model, plan, rollout)."""

from __future__ import annotations

import os
import typing
from dataclasses import fields
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import numpy as np

from dexlfd._validation import check_time
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io._facts import facts_member, from_json, to_json
from dexlfd.io._meta_schema import check_meta_types
from dexlfd.io._npz import RESERVED, ArraySpec, check_arrays, load_npz, save_npz

__all__ = ["Record"]

R = TypeVar("R", bound="Record")


class Record:
    """Frozen dataclass mixin: arrays checked against ``SPECS`` on construction.

    Subclasses are ``@dataclass(frozen=True, eq=False)`` with one field per
    array of ``SPECS`` (same names), then ``meta`` (JSON-able dict) and
    ``extras`` (further named arrays, kept on save/load, e.g. alignment info).
    Construction also checks ``t`` (strictly increasing, ``MIN_SAMPLES`` samples)
    and that the arrays named in ``UNIT_QUATERNIONS`` hold unit quaternions
    (only the ``valid`` rows, if the record has a ``valid`` mask).

    Typed facts: the dataclass fields named in ``FACTS`` (annotated with
    :class:`~dexlfd.io._facts.Fact` types, ``None`` or empty by default) are what a
    later stage reads; they are saved as the file's ``facts`` member and checked
    against their annotations on load. A file of an older ``VERSION`` holds them in
    ``meta``: :meth:`_facts_from_meta` lifts them out on load.
    """

    KIND: ClassVar[str]
    VERSION: ClassVar[int]
    SPECS: ClassVar[dict[str, ArraySpec]]
    MIN_SAMPLES: ClassVar[int] = 2  # fewest samples of ``t``
    UNIT_QUATERNIONS: ClassVar[tuple[str, ...]] = ()  # arrays of unit quaternions (where valid)
    FACTS: ClassVar[tuple[str, ...]] = ()  # the typed fact fields (see dexlfd.io._facts)
    # deflate the members (False: stored, for files of float samples that deflate hardly
    # shrinks and that the next stage reads at once)
    COMPRESS: ClassVar[bool] = True

    t: np.ndarray
    meta: dict[str, Any]
    extras: dict[str, np.ndarray]

    def __post_init__(self) -> None:
        name = type(self).__name__
        values = {n: getattr(self, n) for n in self.SPECS}
        checked = check_arrays(values, self.SPECS, name, InvalidInput)
        for n, arr in checked.items():
            arr.setflags(write=False)
            object.__setattr__(self, n, arr)
        extras = {}
        for key, value in dict(self.extras).items():
            if key in self.SPECS or key in RESERVED:
                raise InvalidInput(f"{name}: extras key {key!r} clashes with a contract array")
            arr = np.asarray(value)
            if arr.dtype == object:
                raise InvalidInput(f"{name}: extras[{key!r}] has dtype object")
            extras[key] = arr
        object.__setattr__(self, "extras", extras)
        object.__setattr__(self, "meta", dict(self.meta))
        check_time(self.t, f"{name}.t", min_len=self.MIN_SAMPLES)
        valid = getattr(self, "valid", None)
        for key in self.UNIT_QUATERNIONS:
            q = getattr(self, key) if valid is None else getattr(self, key)[valid]
            if q.size and not np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-6):
                raise InvalidInput(f"{name}.{key} must be unit quaternions (x, y, z, w)")

    @property
    def n_samples(self) -> int:
        """Number of time samples."""
        return int(np.shape(self.t)[0])

    def _save(self, path: str | os.PathLike[str]) -> Path:
        from dexlfd.io.plausibility import check_plausible

        try:  # the loader's checks, before writing: never a file the next stage refuses
            check_plausible(self, path, warn=False)
        except InvalidFile as exc:
            raise InvalidInput(f"not written: {exc}") from exc
        return self._write(path)

    def _write(self, path: str | os.PathLike[str]) -> Path:
        """Write without the loader's plausibility checks (:meth:`_save` runs them first)."""
        arrays = {n: getattr(self, n) for n in self.SPECS if getattr(self, n) is not None}
        try:
            facts = {n: to_json(getattr(self, n)) for n in self.FACTS}
        except ValueError as exc:
            raise InvalidFile(f"cannot write {path}: {exc}") from exc
        facts = {n: v for n, v in facts.items() if v is not None and v != []}
        return save_npz(path, self.KIND, self.VERSION, {**arrays, **self.extras}, self.meta, facts,
                        compress=self.COMPRESS)  # fmt: skip

    @classmethod
    def _facts_from_meta(
        cls, meta: dict[str, Any], version: int, where: str
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """``(facts, meta)`` of a file written before its facts were typed.

        ``facts`` maps fact-field names to their JSON values (checked like the
        ``facts`` member afterwards); ``meta`` is what stays provenance. The base
        class lifts nothing; a record whose ``VERSION`` moved facts out of ``meta``
        overrides this for the older versions.
        """
        return {}, meta

    @classmethod
    def _read_facts(
        cls, arrays: dict[str, np.ndarray], meta: dict[str, Any], version: int, where: str
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """The typed fact fields of a loaded file and the ``meta`` that remains."""
        raw = facts_member(arrays, where)
        lifted, meta = cls._facts_from_meta(meta, version, where)
        raw = {**lifted, **raw}
        unknown = sorted(set(raw) - set(cls.FACTS))
        if unknown:
            raise InvalidFile(f"{where}: unknown fact {unknown[0]!r} in a {cls.KIND} file")
        hints = typing.get_type_hints(cls)
        facts = {n: from_json(hints[n], v, f"{where}: facts.{n}") for n, v in raw.items()}
        return facts, meta

    @classmethod
    def _load(cls: type[R], path: str | os.PathLike[str]) -> R:
        arrays, meta, version = load_npz(path, cls.KIND, cls.VERSION, cls.SPECS)
        facts, meta = cls._read_facts(arrays, meta, version, str(path))
        check_meta_types(meta, cls.KIND, str(path))
        checked = check_arrays(arrays, cls.SPECS, str(path), InvalidFile)
        extras = {k: v for k, v in arrays.items() if k not in cls.SPECS}
        names = {f.name for f in fields(cls)}  # type: ignore[arg-type]
        kwargs = {k: v for k, v in checked.items() if k in names}
        try:
            record = cls(**kwargs, **facts, meta=meta, extras=extras)  # type: ignore[call-arg]
        except InvalidInput as exc:
            raise InvalidFile(f"{path}: {exc}") from exc
        from dexlfd.io.plausibility import check_plausible

        check_plausible(record, path)
        return record
