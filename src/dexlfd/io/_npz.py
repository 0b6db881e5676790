"""Versioned, self-describing ``.npz`` files with atomic writes and checked loads.

Every file holds ``format_version`` (int), ``meta`` (a JSON string whose
``kind`` names the contract) and the contract's arrays. Files are written to a
temporary file in the target folder and renamed into place, so a crash never
leaves a half-written or clobbered file. Loading never unpickles.
"""

from __future__ import annotations

import io
import json
import os
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from tokenize import TokenError
from typing import Any

import numpy as np

from dexlfd.errors import DexlfdError, InvalidFile
from dexlfd.io._atomic import atomic_write
from dexlfd.io._gate import ZIP_READ_ERRORS, check_zip_members, zip_member

__all__ = ["ArraySpec", "check_arrays", "load_npz", "load_small_npy", "read_npz", "save_npz"]

RESERVED = ("format_version", "meta", "facts")


@dataclass(frozen=True, slots=True)
class ArraySpec:
    """Contract of one array: symbolic shape, dtype kind, where NaN is allowed.

    ``shape`` entries are ints (fixed) or symbols (``"n"``, ``"K"``...) that
    must agree across all arrays of a file. ``nan`` is ``"never"``,
    ``"invalid"`` (exactly where the file's ``valid`` mask is false, on axis 0)
    or ``"any"``.
    """

    shape: tuple[int | str, ...]
    kind: str = "f"  # "f" float, "b" bool, "i" integer
    nan: str = "never"
    unit: str = ""
    required: bool = True


def save_npz(
    path: str | os.PathLike[str],
    kind: str,
    version: int,
    arrays: Mapping[str, np.ndarray],
    meta: Mapping[str, Any],
    facts: Mapping[str, Any] | None = None,
    *,
    compress: bool = True,
) -> Path:
    """Write ``arrays`` plus ``format_version``, JSON ``meta`` and JSON ``facts`` atomically.

    ``facts`` (the typed facts of :mod:`dexlfd.io._facts`, already as JSON values) is
    written as the member ``facts`` when given. ``compress``: deflated members
    (``np.savez_compressed``), else stored ones (``np.savez``).
    """
    from dexlfd import __version__

    path = Path(path)
    full_meta = {"kind": kind, "software": f"dexlfd {__version__}", **dict(meta)}
    full_meta["kind"] = kind
    try:
        meta_json = json.dumps(full_meta, sort_keys=True, default=_json_default)
    except (TypeError, ValueError) as exc:
        raise InvalidFile(f"cannot write {path}: meta is not JSON-serialisable: {exc}") from exc
    payload: dict[str, Any] = {
        "format_version": np.asarray(version, dtype=np.int64),
        "meta": np.asarray(meta_json),
    }
    if facts:
        try:
            payload["facts"] = np.asarray(json.dumps(dict(facts), sort_keys=True, allow_nan=False))
        except (TypeError, ValueError) as exc:
            raise InvalidFile(f"cannot write {path}: a fact is not JSON: {exc}") from exc
    for name, arr in arrays.items():
        if name in RESERVED:
            raise InvalidFile(f"cannot write {path}: array name {name!r} is reserved")
        a = np.asarray(arr)
        if a.dtype == object:
            raise InvalidFile(f"cannot write {path}: array {name!r} has dtype object")
        payload[name] = a
    # the archive is made in memory, then written: a full disk fails the plain write, never
    # numpy's open ZipFile (whose finaliser would then fail a second time, after our error)
    buf = io.BytesIO()
    try:
        (np.savez_compressed if compress else np.savez)(buf, **payload)
    except OSError as exc:
        raise InvalidFile(f"cannot write {path}: {exc.strerror or exc}") from exc
    atomic_write(path, lambda fh: fh.write(buf.getbuffer()))
    return path


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON-serialisable")


# What one file may hold, declared by its array headers and checked before any array is
# read: a crafted header (10^12 elements) or a zip bomb (a small file whose member inflates
# to gigabytes) is refused in one line instead of exhausting memory.
MAX_FILE_BYTES = 2 * 1024**3  # all arrays of one file, uncompressed [bytes]
MAX_EXTRA_BYTES = 256 * 1024**2  # all arrays outside the contract, uncompressed [bytes]


@dataclass(frozen=True, slots=True)
class _Header:
    """One ``.npy`` member's declared array, read from its header only."""

    shape: tuple[int, ...]
    dtype: np.dtype[Any]

    @property
    def nbytes(self) -> int:
        n = 1
        for size in self.shape:
            n *= int(size)
        return n * int(self.dtype.itemsize)


def _npy_header(fh: Any) -> _Header:
    """The array a ``.npy`` stream declares, from its header alone.

    The stream is left just past the header. ``ValueError`` for an unknown version or
    Python objects.
    """
    version = np.lib.format.read_magic(fh)
    read = {
        (1, 0): np.lib.format.read_array_header_1_0,
        (2, 0): np.lib.format.read_array_header_2_0,
        (3, 0): np.lib.format.read_array_header_2_0,
    }.get(version)
    if read is None:
        raise ValueError(f"unsupported .npy version {version}")
    try:
        shape, _fortran, dtype = read(fh)
    except (SyntaxError, TokenError, TypeError, UnicodeDecodeError) as exc:
        # numpy parses the header text as a Python literal: damaged bytes there surface
        # as the tokenizer's or parser's errors
        raise ValueError(f"unreadable .npy header ({type(exc).__name__})") from None
    if dtype.hasobject:
        raise ValueError("holds Python objects (never unpickled)")
    return _Header(tuple(int(s) for s in shape), dtype)


def _read_headers(zf: zipfile.ZipFile, where: str) -> dict[str, _Header]:
    """The declared shape and dtype of every array in the archive, from the headers alone.

    Raises ``ValueError`` for a member that is not a ``.npy`` array, one whose header is
    unreadable or declares objects, and one whose declared data exceeds what the zip
    directory says the member inflates to (a lying header).
    """
    headers: dict[str, _Header] = {}
    for info in zf.infolist():
        if info.is_dir():
            continue
        if not info.filename.endswith(".npy"):
            raise ValueError(f"member {info.filename!r} is not a .npy array")
        name = info.filename[: -len(".npy")]
        with zip_member(where, info.filename, values=False), zf.open(info) as member:
            try:
                head = _npy_header(member)
            except ValueError as exc:
                raise ValueError(f"array {name!r}: {exc}") from None
            header_len = member.tell()
        if header_len + head.nbytes > info.file_size:
            raise ValueError(
                f"array {name!r} declares {head.shape} {head.dtype} ({head.nbytes} bytes) but its "
                f"member holds {info.file_size} bytes"
            )
        headers[name] = head
    return headers


def _check_headers(
    headers: Mapping[str, _Header], specs: Mapping[str, ArraySpec] | None, where: str
) -> None:
    """Refuse, before reading, a file whose declared arrays cannot fit its contract or memory."""
    total = sum(h.nbytes for h in headers.values())
    if total > MAX_FILE_BYTES:
        raise InvalidFile(
            f"{where}: its arrays declare {total / 1024**3:.1f} GiB uncompressed; a dexlfd file "
            f"holds at most {MAX_FILE_BYTES / 1024**3:.0f} GiB"
        )
    if specs is None:
        return
    for name, spec in specs.items():
        head = headers.get(name)
        if head is not None and len(head.shape) != len(spec.shape):
            raise InvalidFile(
                f"{where}: array {name!r} must have shape {_fmt(spec.shape)}, got {head.shape}"
            )
    extra = sum(h.nbytes for n, h in headers.items() if n not in specs and n not in RESERVED)
    if extra > MAX_EXTRA_BYTES:
        raise InvalidFile(
            f"{where}: arrays outside the contract declare {extra / 1024**2:.0f} MiB "
            f"uncompressed (at most {MAX_EXTRA_BYTES / 1024**2:.0f} MiB)"
        )


def read_npz(
    path: str | os.PathLike[str], what: str, specs: Mapping[str, ArraySpec] | None = None
) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` at ``path`` (never unpickled), or :class:`InvalidFile`.

    ``what`` names the expected file in the messages (``"a dexlfd model"``). Every
    array's header is read and checked first (:func:`_check_headers`: the whole file
    at most ``MAX_FILE_BYTES`` uncompressed; with ``specs``, the contract arrays'
    dimensions and at most ``MAX_EXTRA_BYTES`` of other arrays), so nothing is
    inflated that could not be accepted.
    """
    path = Path(path)
    if not path.is_file():
        raise InvalidFile(f"{path}: no such file (expected {what} .npz)")
    try:
        # open the file ourselves: np.load leaks its handle when the zip is truncated
        with open(path, "rb") as fh:
            with zipfile.ZipFile(fh) as zf:
                check_zip_members(zf, str(path))  # encrypted, unreadable compression
                headers = _read_headers(zf, str(path))
            _check_headers(headers, specs, str(path))
            fh.seek(0)
            with np.load(fh, allow_pickle=False) as data:
                if not hasattr(data, "files"):
                    raise ValueError("a bare .npy array, not an .npz archive")
                arrays = {}
                for name in data.files:
                    with zip_member(str(path), f"{name}.npy"):
                        arrays[name] = data[name]
                return arrays
    except (*ZIP_READ_ERRORS, KeyError, TypeError) as exc:
        raise InvalidFile(
            f"{path}: not a readable .npz file ({type(exc).__name__}: {exc}); expected {what} file"
        ) from exc


def load_npz(
    path: str | os.PathLike[str],
    kind: str,
    max_version: int,
    specs: Mapping[str, ArraySpec] | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, Any], int]:
    """Read a dexlfd ``.npz``; check it exists, is ours, of ``kind`` and a known version.

    Every array's header is read and checked first (:func:`_check_headers`: the whole
    file at most ``MAX_FILE_BYTES`` uncompressed; with ``specs``, the contract arrays'
    dimensions and at most ``MAX_EXTRA_BYTES`` of other arrays), so nothing is inflated
    that could not be accepted. Returns ``(arrays, meta, version)``. Shapes are checked
    in full by :func:`check_arrays`.
    """
    path = Path(path)
    arrays = read_npz(path, f"a dexlfd {kind}", specs)
    if "meta" not in arrays or "format_version" not in arrays:
        raise InvalidFile(
            f"{path}: not a dexlfd file (no 'meta'/'format_version'); expected {kind}"
        )
    try:
        meta = json.loads(str(arrays.pop("meta")))
        version = int(arrays.pop("format_version"))
    except (ValueError, TypeError, RecursionError) as exc:
        raise InvalidFile(f"{path}: unreadable 'meta' or 'format_version': {exc}") from exc
    if not isinstance(meta, dict):
        raise InvalidFile(f"{path}: 'meta' must be a JSON object")
    if meta.get("kind") != kind:
        raise InvalidFile(f"{path}: is a {meta.get('kind')!r} file, expected a {kind!r} file")
    if not 1 <= version <= max_version:
        raise InvalidFile(
            f"{path}: {kind} format_version {version} is not supported "
            f"(this dexlfd reads 1..{max_version}); upgrade dexlfd"
        )
    return arrays, meta, version


def load_small_npy(path: Path, max_elements: int) -> np.ndarray:
    """A ``.npy`` array of at most ``max_elements``, its header checked before any read.

    Raises ``ValueError`` (the callers name the parameter) for an unreadable header, an
    object array, more than ``max_elements`` declared, or a header that declares more
    data than the file holds.
    """
    with open(path, "rb") as fh:
        head = _npy_header(fh)
        dtype = head.dtype
        n = head.nbytes // max(int(dtype.itemsize), 1)
        if n > max_elements:
            raise ValueError(f"declares {head.shape}: more than {max_elements} elements")
        if fh.tell() + head.nbytes > path.stat().st_size:
            raise ValueError(f"declares {head.shape} {dtype} but the file is shorter")
    return np.load(path, allow_pickle=False)


def check_arrays(
    arrays: Mapping[str, Any],
    specs: Mapping[str, ArraySpec],
    where: str,
    err: type[DexlfdError] = InvalidFile,
) -> dict[str, np.ndarray]:
    """Check names, dtypes, symbolic shapes and NaN policy; return converted arrays.

    ``where`` prefixes error messages (a file path or a class name); ``err`` is
    the exception raised.
    """
    sizes: dict[str, int] = {}
    out: dict[str, np.ndarray] = {}
    for name, spec in specs.items():
        if name not in arrays or arrays[name] is None:
            if spec.required:
                raise err(f"{where}: missing array {name!r}")
            continue
        raw = np.asarray(arrays[name])
        try:
            if raw.dtype.kind not in "biuf":  # complex, strings, objects, dates: no cast
                raise TypeError("expected numbers")
            if spec.kind == "f":
                a = raw.astype(np.float64, copy=False)
            elif spec.kind == "b":
                if raw.dtype != np.bool_ and not np.isin(raw, (0, 1)).all():
                    raise ValueError("values other than 0/1")
                a = raw.astype(np.bool_, copy=False)
            else:
                if raw.dtype.kind == "f" and not np.equal(np.mod(raw, 1), 0).all():
                    raise ValueError("non-integer values")
                a = raw.astype(np.int64, copy=False)
        except (TypeError, ValueError) as exc:
            raise err(f"{where}: array {name!r} has wrong type {raw.dtype}: {exc}") from exc
        if a.ndim != len(spec.shape):
            raise err(f"{where}: array {name!r} must have shape {_fmt(spec.shape)}, got {a.shape}")
        for sym, size in zip(spec.shape, a.shape, strict=True):
            if isinstance(sym, int):
                ok = size == sym
            else:
                ok = sizes.setdefault(sym, size) == size
            if not ok:
                raise err(
                    f"{where}: array {name!r} must have shape {_fmt(spec.shape)} "
                    f"with {_fmt_sizes(sizes)}, got {a.shape}"
                )
        out[name] = a
    valid = out.get("valid")
    for name, spec in specs.items():
        arr = out.get(name)
        if arr is None or spec.kind != "f":
            continue
        a = arr
        if a.size == 0:
            continue  # no samples: the time axis's own check says so
        if np.isinf(a).any():  # NaN may mean "not seen"; inf never means anything
            i = int(np.argmax(np.isinf(a).reshape(a.shape[0], -1).any(axis=1))) if a.ndim else 0
            raise err(f"{where}: array {name!r} contains inf (at sample {i})")
        if spec.nan == "any":
            continue
        nan_rows = np.isnan(a).reshape(a.shape[0], -1).any(axis=1) if a.ndim else np.isnan(a)
        if spec.nan == "never" and np.any(nan_rows):
            raise err(f"{where}: array {name!r} contains NaN")
        if spec.nan == "invalid" and valid is not None:
            all_nan = np.isnan(a).reshape(a.shape[0], -1).all(axis=1)
            if (nan_rows & valid).any():
                i = int(np.argmax(nan_rows & valid))
                raise err(f"{where}: array {name!r} has NaN at sample {i}, where valid is true")
            if name != "keypoints" and (~all_nan & ~valid).any():
                i = int(np.argmax(~all_nan & ~valid))
                raise err(
                    f"{where}: array {name!r} must be NaN at sample {i}, where valid is false"
                )
    return out


def _fmt(shape: tuple[int | str, ...]) -> str:
    return "(" + ", ".join(str(s) for s in shape) + ")"


def _fmt_sizes(sizes: Mapping[str, int]) -> str:
    return ", ".join(f"{k}={v}" for k, v in sizes.items()) or "no sizes fixed yet"
