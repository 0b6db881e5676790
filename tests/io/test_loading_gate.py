"""The loading gate: array headers are checked before any array is inflated."""

from __future__ import annotations

import io
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dexlfd.errors import InvalidFile
from dexlfd.io import Plan, load_plan, save_plan
from dexlfd.io._npz import MAX_EXTRA_BYTES, MAX_FILE_BYTES


def _plan_file(tmp_path: Path) -> Path:
    n = 5
    z = np.zeros((n, 3))
    plan = Plan(
        t=np.arange(n) * 0.1,
        position=z,
        velocity=z,
        acceleration=z,
        quaternion=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
        angular_velocity=z,
        gripper=np.full(n, 0.04),
    )
    return save_plan(tmp_path / "plan.npz", plan)


def _npy_header(shape: tuple[int, ...], dtype: str = "<f8") -> bytes:
    buf = io.BytesIO()
    header = {"descr": dtype, "fortran_order": False, "shape": shape}
    np.lib.format.write_array_header_1_0(buf, header)
    return buf.getvalue()


def _with_member(src: Path, dst: Path, name: str, payload: bytes, compress: bool) -> Path:
    """Copy ``src`` with member ``name.npy`` replaced by (or added as) ``payload``."""
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", method) as zout:
        for item in zin.infolist():
            if item.filename != f"{name}.npy":
                zout.writestr(item.filename, zin.read(item.filename))
        zout.writestr(f"{name}.npy", payload)
    return dst


def test_header_claiming_1e12_elements_is_refused_before_reading(tmp_path: Path) -> None:
    src = _plan_file(tmp_path)
    bad = _with_member(
        src, tmp_path / "bad.npz", "gripper", _npy_header((10**12,)) + b"\0" * 64, False
    )
    with pytest.raises(InvalidFile, match=r"bad\.npz.*'gripper'.*declares"):
        load_plan(bad)


def test_zip_bomb_extra_array_is_refused_without_inflating_it(tmp_path: Path) -> None:
    """A small file whose extra array inflates past the bound: refused, memory stays small."""
    src = _plan_file(tmp_path)
    n = MAX_EXTRA_BYTES // 8 + 1024  # float64 zeros, just over the bound
    payload = _npy_header((n,)) + bytes(n * 8)
    bomb = _with_member(src, tmp_path / "bomb.npz", "junk", payload, True)
    assert bomb.stat().st_size < MAX_EXTRA_BYTES // 100  # zeros compress ~1000:1
    del payload
    tracemalloc.start()
    try:
        with pytest.raises(InvalidFile, match=r"bomb\.npz: arrays outside the contract"):
            load_plan(bomb)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 16 * 1024**2  # the member was never inflated


def test_contract_array_with_wrong_dimensions_is_named(tmp_path: Path) -> None:
    src = _plan_file(tmp_path)
    buf = io.BytesIO()
    np.save(buf, np.zeros((5, 3, 2)))
    bad = _with_member(src, tmp_path / "dims.npz", "position", buf.getvalue(), True)
    with pytest.raises(InvalidFile, match=r"dims\.npz: array 'position' must have shape"):
        load_plan(bad)


def test_whole_file_bound_is_above_any_contract_use() -> None:
    # a 1 kHz rollout of the longest plan a command accepts is far below the bound
    assert MAX_FILE_BYTES >= 1024**3


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    shape=st.lists(st.integers(0, 10**9), min_size=0, max_size=4).map(tuple),
    dtype=st.sampled_from(["<f8", "<f4", "|b1", "<i8", "|u1", "<c16", "|O"]),
    compress=st.booleans(),
    name=st.sampled_from(["t", "position", "gripper", "extra_thing"]),
    body=st.integers(0, 256),
)
def test_crafted_headers_never_escape_the_gate(
    tmp_path: Path, shape, dtype, compress, name, body
) -> None:
    """Any crafted header: a plan or one line naming the file; never another exception."""
    src = _plan_file(tmp_path)
    try:
        header = _npy_header(shape, dtype)
    except ValueError:
        return  # numpy cannot even write such a header
    bad = _with_member(src, tmp_path / "crafted.npz", name, header + b"\0" * body, compress)
    try:
        load_plan(bad)
    except InvalidFile as exc:
        assert "crafted.npz" in str(exc)
        assert "\n" not in str(exc)


def test_npy_extrinsics_with_a_crafted_header_is_one_line(tmp_path: Path) -> None:
    from dexlfd.capture.calibration_files import load_extrinsics
    from dexlfd.errors import InvalidInput

    bad = tmp_path / "T.npy"
    bad.write_bytes(_npy_header((10**6, 10**6)) + b"\0" * 128)
    with pytest.raises(InvalidInput, match=r"T\.npy: cannot read a \.npy array: declares"):
        load_extrinsics(bad)


def test_deeply_nested_json_intrinsics_is_one_line(tmp_path: Path) -> None:
    from dexlfd.capture.calibration_files import load_intrinsics
    from dexlfd.errors import InvalidInput

    path = tmp_path / "K.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(InvalidInput, match=r"K\.json: JSON nested too deeply"):
        load_intrinsics(str(path))


def test_kind_of_a_file_whose_meta_is_not_an_object(tmp_path: Path) -> None:
    from dexlfd.io.kinds import load_any

    path = tmp_path / "list.npz"
    np.savez(path, meta=np.asarray("[1, 2]"), format_version=np.asarray(1))
    with pytest.raises(InvalidFile, match=r"list\.npz: unknown kind None"):
        load_any(path)


@pytest.mark.parametrize("kind", ["demonstration", "model", "plan", "rollout"])
def test_a_file_with_zero_samples_is_one_line(tmp_path: Path, kind: str) -> None:
    """Every array cut to 0 samples along time: refused by the time axis's check, in one line."""
    import importlib

    fuzz = importlib.import_module("tests.test_fuzz_loaders")
    from dexlfd.io.kinds import LOADERS

    src = tmp_path / "ok.npz"
    src.write_bytes(fuzz._valid_bytes(kind, tmp_path))
    with np.load(src, allow_pickle=False) as z:
        n = z["t"].shape[0]
        cut = {k: (z[k][:0] if z[k].ndim and z[k].shape[0] == n else z[k]) for k in z.files}
    np.savez(tmp_path / "zero.npz", **cut)
    with pytest.raises(InvalidFile, match=r"zero\.npz: .*at least \d samples, got 0"):
        LOADERS[kind](tmp_path / "zero.npz")


def test_a_corrupt_deflate_stream_is_one_line(tmp_path: Path) -> None:
    """Bytes flipped inside a compressed member (the zip directory intact): InvalidFile."""
    src = _plan_file(tmp_path)
    with zipfile.ZipFile(src) as zf:
        info = zf.getinfo("position.npy")
        start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    raw = bytearray(src.read_bytes())
    for k in range(start + 2, start + info.compress_size - 2):
        raw[k] ^= 0x5A
    bad = tmp_path / "deflate.npz"
    bad.write_bytes(bytes(raw))
    with pytest.raises(InvalidFile, match=r"deflate\.npz: not a readable \.npz file"):
        load_plan(bad)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    damage=st.lists(st.tuples(st.integers(10, 117), st.integers(0, 255)), min_size=1, max_size=6),
    name=st.sampled_from(["t", "gripper"]),
)
def test_damaged_header_text_is_one_line(tmp_path: Path, damage, name) -> None:
    """Bytes changed inside the header's text (numpy parses it as a literal): one line."""
    src = _plan_file(tmp_path)
    header = bytearray(_npy_header((5,)))
    for at, value in damage:
        header[at] = value
    bad = _with_member(src, tmp_path / "damaged.npz", name, bytes(header) + b"\0" * 40, False)
    try:
        load_plan(bad)
    except InvalidFile as exc:
        assert "damaged.npz" in str(exc) and "\n" not in str(exc)


def test_an_unterminated_header_literal_is_one_line(tmp_path: Path) -> None:
    src = _plan_file(tmp_path)
    text = b"{'descr': '<f8', 'fortran_order': False, 'shape': (5,"
    text = text + b" " * (117 - len(text)) + b"\n"  # the 1.0 header's padded length
    header = b"\x93NUMPY\x01\x00" + len(text).to_bytes(2, "little") + text
    bad = _with_member(src, tmp_path / "open.npz", "t", header + b"\0" * 40, False)
    with pytest.raises(InvalidFile, match=r"open\.npz.*'t'.*unreadable \.npy header"):
        load_plan(bad)


@pytest.mark.parametrize("kind", ["demonstration", "plan", "rollout"])
@pytest.mark.parametrize("length", [0, 3, -1, +1])
def test_a_grasp_array_off_the_time_axis_is_refused(tmp_path: Path, kind: str, length: int) -> None:
    """``grasp`` is (n,) in every contract that has it: any other length is an error naming
    the file and the array, never a warning."""
    import importlib

    fuzz = importlib.import_module("tests.test_fuzz_loaders")
    from dexlfd.io.kinds import LOADERS

    src = tmp_path / "ok.npz"
    src.write_bytes(fuzz._valid_bytes(kind, tmp_path))
    with np.load(src, allow_pickle=False) as z:
        members = {k: z[k] for k in z.files}
    n = members["t"].shape[0]
    size = length if length in (0, 3) else n + length
    members["grasp"] = np.ones(size, bool)
    np.savez(tmp_path / "bad.npz", **members)
    message = rf"bad\.npz: array 'grasp' must have shape \(n\) .*n={n}"
    with pytest.raises(InvalidFile, match=message):
        LOADERS[kind](tmp_path / "bad.npz")
