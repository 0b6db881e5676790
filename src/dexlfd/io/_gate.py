"""One loading gate: every zip- and parquet-level failure is one line naming file and member.

The readers of :mod:`dexlfd.io` (``.npz`` archives, LeRobot datasets) go through here, so
a damaged or unusual file never reaches the user as a traceback:

- zip (``.npz``): :func:`check_zip_members` refuses, before any data is read, a member
  whose header says encrypted or compressed with a method Python's :mod:`zipfile` does
  not read (zstd 93, AES 99, ...); :func:`zip_member` turns what reading a member's
  damaged stream raises (``zlib.error``, ``lzma.LZMAError``, a bad CRC, a short stream)
  into :class:`~dexlfd.errors.InvalidFile` naming the member;
- parquet (LeRobot): :func:`parquet_rows` reads the row count from the files' footers
  and refuses, before any table is read, more rows than fit the memory bound;
  :func:`table_column` names a missing column or one of the wrong type;
  :func:`json_text` refuses JSON that is not JSON, nests deeper than Python can parse,
  or is not the expected type.
"""

from __future__ import annotations

import json
import lzma
import zipfile
import zlib
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.errors import InvalidFile

__all__ = [
    "MAX_TABLE_BYTES",
    "ZIP_READ_ERRORS",
    "check_zip_members",
    "json_text",
    "numeric_list_column",
    "parquet_rows",
    "table_column",
    "zip_member",
]

# what zipfile can decompress: stored, deflate, bzip2, LZMA
_ZIP_METHODS = {0: "stored", 8: "deflate", 12: "bzip2", 14: "LZMA"}
_KNOWN_METHODS = {9: "deflate64", 93: "zstd", 95: "xz", 96: "JPEG", 97: "WavPack",
                  98: "PPMd", 99: "AES encryption"}  # fmt: skip
# what reading a damaged member raises (the stream's codec, the CRC check, a cut stream)
ZIP_READ_ERRORS = (
    zipfile.BadZipFile,
    zlib.error,
    lzma.LZMAError,
    EOFError,
    OSError,
    ValueError,
    RuntimeError,
    NotImplementedError,
)
# what decompressing a damaged stream raises (a ValueError is a reader's own complaint)
_STREAM_ERRORS: tuple[type[BaseException], ...] = tuple(
    e for e in ZIP_READ_ERRORS if e is not ValueError
)
MAX_TABLE_BYTES = 2 * 1024**3  # a dataset's columns dexlfd reads, as float64 [bytes]


def check_zip_members(zf: zipfile.ZipFile, where: str) -> None:
    """Refuse an encrypted member or one compressed with a method zipfile cannot read."""
    for info in zf.infolist():
        if info.flag_bits & 0x1:
            raise InvalidFile(
                f"{where}: member {info.filename!r} is encrypted (a password-protected zip); "
                "dexlfd reads unencrypted archives only"
            )
        method = info.compress_type
        if method not in _ZIP_METHODS:
            name = _KNOWN_METHODS.get(method, "unknown")
            raise InvalidFile(
                f"{where}: member {info.filename!r} is compressed with method {method} "
                f"({name}), which cannot be read; expected one of "
                f"{', '.join(_ZIP_METHODS.values())} (numpy's savez_compressed uses deflate)"
            )


@contextmanager
def zip_member(where: str, member: str, *, values: bool = True) -> Iterator[None]:
    """A damaged member's read error as one :class:`InvalidFile` naming file and member.

    With ``values=False`` a ``ValueError`` (a header's content refused by its reader)
    passes through unchanged; only the stream's errors are called damage.
    """
    caught: tuple[type[BaseException], ...] = ZIP_READ_ERRORS if values else _STREAM_ERRORS
    try:
        yield
    except caught as exc:
        raise InvalidFile(
            f"{where}: not a readable .npz file: member {member!r} is damaged "
            f"({type(exc).__name__}: {exc})"
        ) from exc


def parquet_rows(pq: Any, files: Sequence[Path], where: str, bytes_per_row: int) -> int:
    """Rows of ``files`` from their footers; refused past :data:`MAX_TABLE_BYTES` of columns.

    ``bytes_per_row`` is what one row costs once read (its float64 columns): a 1 MB file
    of 20 million identical rows (run-length encoded) is refused here, before it is
    inflated to gigabytes.
    """
    import pyarrow as pa

    total = 0
    for f in files:
        try:
            with open(f, "rb") as fh:  # pyarrow's own paths must be UTF-8
                total += int(pq.ParquetFile(fh).metadata.num_rows)
        except (OSError, pa.ArrowException) as exc:
            raise InvalidFile(f"{f}: unreadable parquet ({exc})") from exc
    need = total * int(bytes_per_row)
    if need > MAX_TABLE_BYTES:
        raise InvalidFile(
            f"{where}: {total:,} rows would take {need / 1024**3:.1f} GiB once read; dexlfd "
            f"reads at most {MAX_TABLE_BYTES / 1024**3:.0f} GiB ("
            f"{MAX_TABLE_BYTES // max(int(bytes_per_row), 1):,} rows of this dataset)"
        )
    return total


def table_column(table: Any, key: str, where: Path | str, dtype: Any) -> np.ndarray:
    """Column ``key`` of an Arrow table as an array of ``dtype``, or one line why not.

    Numbers only (a column of text that happens to parse as numbers is refused), no empty
    cells; an integer column may be stored as whole floats within float64's exact range.
    """
    if key not in table.column_names:
        raise InvalidFile(f"{where}: no column {key!r} in the parquet table")
    col = table.column(key)
    if col.null_count:
        raise InvalidFile(f"{where}: column {key!r} has {col.null_count} empty (null) values")
    arr = np.asarray(col.to_numpy())
    want = np.dtype(dtype)
    ok = arr.dtype.kind in "iu" or (arr.dtype.kind == "f" and want.kind == "f")
    if arr.dtype.kind == "f" and want.kind in "iu":
        with np.errstate(invalid="ignore"):
            ok = bool(np.all(np.isfinite(arr) & (np.mod(arr, 1) == 0) & (np.abs(arr) < 2**53)))
    if arr.dtype.kind in "iu" and want.kind in "iu" and arr.size:
        ok = bool(np.iinfo(want).min <= arr.min() and arr.max() <= np.iinfo(want).max)
    if not ok:
        raise InvalidFile(
            f"{where}: column {key!r} holds {table.schema.field(key).type} values, expected "
            f"{'whole numbers' if want.kind in 'iu' else 'numbers'} ({want.name})"
        )
    return arr.astype(want)


def numeric_list_column(table: Any, key: str, where: Path | str) -> None:
    """Refuse a list column (``observation.state``) whose items are not numbers."""
    import pyarrow as pa

    kind = table.schema.field(key).type
    item = getattr(kind, "value_type", kind)
    if not (pa.types.is_floating(item) or pa.types.is_integer(item)):
        raise InvalidFile(f"{where}: column {key!r} holds {kind}, expected lists of numbers")


def json_text(text: Any, where: str, expected: type = dict) -> Any:
    """``text`` parsed as JSON of type ``expected``, or one :class:`InvalidFile` line."""
    try:
        value = json.loads(text)
    except (ValueError, TypeError, RecursionError) as exc:
        what = "nests too deeply" if isinstance(exc, RecursionError) else "is not JSON"
        raise InvalidFile(f"{where}: {what} ({type(exc).__name__})") from None
    if not isinstance(value, expected):
        raise InvalidFile(
            f"{where}: expected a JSON {_json_name(expected)}, got a {type(value).__name__}"
        )
    return value


def _json_name(kind: type) -> str:
    names: dict[type, str] = {dict: "object", list: "array", str: "string"}
    return names.get(kind, kind.__name__)
