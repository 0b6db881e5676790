"""The loading gate under fuzzing: zip member headers and LeRobot tables.

Whatever a member's header flags, compression method or stream bytes say, and whatever a
LeRobot dataset's tables and JSON hold, loading either succeeds or raises one
:class:`InvalidFile` whose message names the file (and the member, at zip level).
"""

from __future__ import annotations

import io
import json
import shutil
import struct
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.errors import InvalidFile
from dexlfd.io import save_demonstration
from dexlfd.io.kinds import kind_of, load_any

FUZZ = settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


@pytest.fixture(scope="module")
def good(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    demo = pick_place_demonstrations(1, np.random.default_rng(3))[0]
    return save_demonstration(tmp_path_factory.mktemp("g") / "d.npz", demo).read_bytes()


def _headers(data: bytes, member: str) -> tuple[int, list[int]]:
    """The offset of ``member``'s local header and of its central directory entries."""
    info = zipfile.ZipFile(io.BytesIO(data)).getinfo(member)
    central, at = [], data.find(b"PK\x01\x02")
    while at != -1:
        n = struct.unpack_from("<H", data, at + 28)[0]
        if data[at + 46 : at + 46 + n].decode() == member:
            central.append(at)
        at = data.find(b"PK\x01\x02", at + 4)
    return info.header_offset, central


def _patched(data: bytes, member: str, flags: int | None, method: int | None) -> bytes:
    b = bytearray(data)
    local, central = _headers(data, member)
    for off, flag_at, method_at in [(local, 6, 8)] + [(c, 8, 10) for c in central]:
        if flags is not None:
            struct.pack_into("<H", b, off + flag_at, flags)
        if method is not None:
            struct.pack_into("<H", b, off + method_at, method)
    return bytes(b)


def _damaged(data: bytes, member: str, at: float, xor: int, length: int) -> bytes:
    b = bytearray(data)
    info = zipfile.ZipFile(io.BytesIO(data)).getinfo(member)
    n, x = struct.unpack_from("<HH", b, info.header_offset + 26)
    start = info.header_offset + 30 + n + x
    first = start + int(at * max(info.compress_size - 1, 0))
    for i in range(first, min(first + length, start + info.compress_size)):
        b[i] ^= xor
    return bytes(b)


def _recompressed(data: bytes, member: str, method: int) -> bytes:
    zin, out = zipfile.ZipFile(io.BytesIO(data)), io.BytesIO()
    with zipfile.ZipFile(out, "w") as zo:
        for info in zin.infolist():
            kind = method if info.filename == member else zipfile.ZIP_DEFLATED
            zo.writestr(info.filename, zin.read(info.filename), compress_type=kind)
    return out.getvalue()


def _one_line_or_loads(path: Path, member: str, zip_level: bool) -> None:
    for load in (kind_of, load_any):
        try:
            load(path)
        except InvalidFile as exc:
            text = str(exc)
            assert "\n" not in text and str(path) in text, text
            if zip_level:
                assert member in text, text


MEMBERS = st.sampled_from(["meta.npy", "format_version.npy", "t.npy", "position.npy"])


@FUZZ
@given(member=MEMBERS, flags=st.integers(0, 0xFFFF), method=st.integers(0, 0xFFFF))
def test_any_member_flags_and_method_are_one_line(tmp_path, good, member, flags, method) -> None:
    path = tmp_path / "x.npz"
    path.write_bytes(_patched(good, member, flags, method))
    zip_level = bool(flags & 1) or method not in (0, 8, 12, 14)
    _one_line_or_loads(path, member, zip_level)


@FUZZ
@given(
    member=MEMBERS,
    method=st.sampled_from([zipfile.ZIP_DEFLATED, zipfile.ZIP_LZMA, zipfile.ZIP_BZIP2]),
    at=st.floats(0, 1),
    xor=st.integers(1, 255),
    length=st.integers(1, 64),
)
def test_damaged_streams_are_one_line(tmp_path, good, member, method, at, xor, length) -> None:
    path = tmp_path / "x.npz"
    path.write_bytes(_damaged(_recompressed(good, member, method), member, at, xor, length))
    _one_line_or_loads(path, member, zip_level=False)


@pytest.mark.parametrize(("method", "name"), [(93, "zstd"), (99, "AES"), (9, "deflate64")])
def test_unsupported_compression_names_file_member_and_method(tmp_path, good, method, name):
    path = tmp_path / "x.npz"
    path.write_bytes(_patched(good, "meta.npy", None, method))
    with pytest.raises(InvalidFile, match=rf"x\.npz: member 'meta\.npy' .*{method} \({name}"):
        load_any(path)
    path.write_bytes(_patched(good, "t.npy", 0x1, None))
    with pytest.raises(InvalidFile, match=r"member 't\.npy' is encrypted"):
        load_any(path)


# ------------------------------------------------------------------------------- LeRobot

pq = pytest.importorskip("pyarrow.parquet", reason="pyarrow not installed")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from dexlfd.io.lerobot import export_lerobot

    demos = pick_place_demonstrations(2, np.random.default_rng(4))
    return export_lerobot(demos, tmp_path_factory.mktemp("lr") / "ds")


def _copy(dataset: Path, tmp_path: Path) -> Path:
    root = tmp_path / "ds"
    if root.exists():
        shutil.rmtree(root)
    shutil.copytree(dataset, root)
    return root


def _rewrite(root: Path, folder: str, change) -> None:  # type: ignore[no-untyped-def]
    for f in sorted((root / folder).glob("chunk-*/file-*.parquet")):
        pq.write_table(change(pq.read_table(f)), f)


def _refused(root: Path) -> str:
    from dexlfd.io.lerobot import import_lerobot

    with pytest.raises(InvalidFile) as exc:
        import_lerobot(root)
    text = str(exc.value)
    assert "\n" not in text and str(root) in text, text
    return text


@pytest.mark.parametrize("column", ["episode_index", "timestamp", "frame_index"])
def test_a_missing_data_column_is_named(dataset, tmp_path, column) -> None:
    root = _copy(dataset, tmp_path)
    _rewrite(root, "data", lambda t: t.drop_columns([column]))
    assert column in _refused(root)


def test_strings_in_the_state_are_named(dataset, tmp_path) -> None:
    import pyarrow as pa

    root = _copy(dataset, tmp_path)

    def strings(t):  # type: ignore[no-untyped-def]
        i = t.column_names.index("observation.state")
        values = [[str(v) for v in row] for row in t.column(i).to_pylist()]
        return t.set_column(i, "observation.state", pa.array(values))

    _rewrite(root, "data", strings)
    assert "observation.state" in _refused(root)


@pytest.mark.parametrize(
    "features",
    [[], "x", None, {"observation.state": []}, {"observation.state": {"names": "xyz"}}],
)
def test_features_of_the_wrong_shape_are_one_line(dataset, tmp_path, features) -> None:
    root = _copy(dataset, tmp_path)
    info_path = root / "meta" / "info.json"
    info = json.loads(info_path.read_text())
    info["features"] = features
    info_path.write_text(json.dumps(info))
    assert "info.json" in _refused(root)


def test_info_nested_100000_levels_is_one_line(dataset, tmp_path) -> None:
    root = _copy(dataset, tmp_path)
    (root / "meta" / "info.json").write_text("[" * 100_000 + "]" * 100_000)
    assert "nests too deeply" in _refused(root)


def test_per_episode_meta_that_is_not_json_is_named(dataset, tmp_path) -> None:
    import pyarrow as pa

    root = _copy(dataset, tmp_path)

    def garbage(t):  # type: ignore[no-untyped-def]
        i = t.column_names.index("dexlfd/meta")
        return t.set_column(i, "dexlfd/meta", pa.array(["{not json"] * t.num_rows))

    _rewrite(root, "meta/episodes", garbage)
    assert "dexlfd/meta" in _refused(root)


def test_too_many_rows_are_refused_from_the_footer(dataset, tmp_path, monkeypatch) -> None:
    """A table whose rows would not fit is refused before any table is read."""
    from dexlfd.io import _gate

    root = _copy(dataset, tmp_path)
    n = pq.ParquetFile(next((root / "data").glob("chunk-*/file-*.parquet"))).metadata.num_rows
    monkeypatch.setattr(_gate, "MAX_TABLE_BYTES", n * 100)  # below one row's ~600 bytes each

    read = pq.read_table

    def no_data_read(source, *args, **kwargs):  # type: ignore[no-untyped-def]
        path = Path(getattr(source, "name", source))  # a path or an open file
        assert "data" not in path.parts, "a data table was read before the size check"
        return read(source, *args, **kwargs)

    monkeypatch.setattr(pq, "read_table", no_data_read)
    text = _refused(root)
    assert f"{n:,} rows" in text and "GiB" in text


@FUZZ
@given(
    column=st.sampled_from(["episode_index", "frame_index", "timestamp", "observation.state"]),
    value=st.sampled_from(["text", None, 1e300, -1, 2**62, float("nan")]),
)
def test_random_cell_values_are_loaded_or_one_line(dataset, tmp_path, column, value) -> None:
    import pyarrow as pa

    from dexlfd.io.lerobot import import_lerobot

    root = _copy(dataset, tmp_path)

    def set_cell(t):  # type: ignore[no-untyped-def]
        i = t.column_names.index(column)
        rows = t.column(i).to_pylist()
        rows[0] = [value] * len(rows[0]) if isinstance(rows[0], list) else value
        try:
            arr = pa.array(rows)
        except (pa.ArrowException, OverflowError):
            arr = pa.array([str(r) for r in rows])
        return t.set_column(i, column, arr)

    _rewrite(root, "data", set_cell)
    try:
        import_lerobot(root)
    except InvalidFile as exc:
        assert "\n" not in str(exc) and str(root) in str(exc)
