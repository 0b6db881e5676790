"""Property/fuzz tests of the file loaders: hostile files give InvalidFile, only.

Each loader sees random bytes, truncated files, archives with random members (wrong
dtypes, shapes, NaN/inf, pickled objects, foreign meta) and valid files with one array
mutated. The property: the load either returns a record that satisfies its contract or
raises :class:`~dexlfd.errors.InvalidFile` naming the file - never another exception, a
numpy warning (pytest turns warnings into errors) or an unpickled object.
"""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from dexlfd.errors import InvalidFile
from dexlfd.io import (
    Demonstration,
    LearnedModel,
    Plan,
    Rollout,
    save_demonstration,
    save_model,
    save_plan,
    save_rollout,
)
from dexlfd.io.kinds import LOADERS, load_any

FUZZ = settings(
    max_examples=60,
    deadline=None,  # a busy shared machine: no per-example time limit
    derandomize=True,  # the same cases on every run
    database=None,  # no .hypothesis folder in the checkout
    phases=[Phase.explicit, Phase.generate],  # no shrinking: minutes of CPU on a failure
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
KINDS = sorted(LOADERS)


def _valid(kind: str) -> object:
    n = 12
    t = np.arange(n) * 0.05
    z = np.zeros((n, 3)) + 0.3
    q = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    if kind == "demonstration":
        return Demonstration(t=t, keypoints=np.full((n, 21, 3), 0.3), valid=np.ones(n, bool),
                             position=z, quaternion=q, gripper=np.full(n, 0.05),
                             grasp=np.zeros(n, bool))  # fmt: skip
    if kind == "model":
        mean = np.concatenate([z, q, np.full((n, 1), 0.04)], axis=1)
        return LearnedModel(t=t, mean=mean, cov=np.tile(np.eye(8) * 1e-4, (n, 1, 1)),
                            gmm_weights=np.array([0.5, 0.5]), gmm_means=np.zeros((2, 9)),
                            gmm_covs=np.tile(np.eye(9), (2, 1, 1)))  # fmt: skip
    if kind == "plan":
        return Plan(t=t, position=z, velocity=z * 0, acceleration=z * 0, quaternion=q,
                    angular_velocity=z * 0, gripper=np.full(n, 0.04))  # fmt: skip
    return Rollout(t=t, q=np.zeros((n, 7)), dq=np.zeros((n, 7)), tau=np.zeros((n, 7)),
                   ee_position=z, ee_quaternion=q, ref_position=z, ref_quaternion=q,
                   gripper=np.full(n, 0.04))  # fmt: skip


SAVERS = {"demonstration": save_demonstration, "model": save_model, "plan": save_plan,
          "rollout": save_rollout}  # fmt: skip


def _valid_bytes(kind: str, tmp: Path) -> bytes:
    path = SAVERS[kind](tmp / f"valid_{kind}.npz", _valid(kind))  # type: ignore[arg-type]
    return path.read_bytes()


def _load_or_invalid(kind: str, path: Path) -> object | None:
    """The property itself: a record of ``kind`` or InvalidFile naming ``path``."""
    try:
        record = LOADERS[kind](path)
    except InvalidFile as exc:
        assert str(path) in str(exc)
        return None
    assert kind == record.KIND
    for name, spec in record.SPECS.items():
        arr = getattr(record, name)
        if arr is None:  # an optional array the file does not have
            assert not spec.required
            continue
        if spec.kind == "f" and spec.nan == "never":
            assert np.isfinite(arr).all()
    return record


@FUZZ
@given(kind=st.sampled_from(KINDS), data=st.binary(max_size=2048))
def test_random_bytes(tmp_path: Path, kind: str, data: bytes) -> None:
    path = tmp_path / "f.npz"
    path.write_bytes(data)
    assert _load_or_invalid(kind, path) is None


@FUZZ
@given(kind=st.sampled_from(KINDS), cut=st.floats(0.0, 0.999))
def test_truncated_files(tmp_path: Path, kind: str, cut: float) -> None:
    data = _valid_bytes(kind, tmp_path)
    path = tmp_path / "cut.npz"
    path.write_bytes(data[: int(cut * len(data))])
    assert _load_or_invalid(kind, path) is None


DTYPES = st.sampled_from(
    ["float64", "float32", "float16", "int64", "int8", "uint8", "bool", "complex128", "U3", "S2"]
)
SPECIAL = st.sampled_from([np.nan, np.inf, -np.inf, 1e308, -1e308, 1e200, 0.0, -5.0, 1e-320])


@st.composite
def arrays(draw: st.DrawFn) -> np.ndarray:
    """A small array of any dtype: seeded normal values plus a few special ones."""
    shape = tuple(draw(st.lists(st.integers(0, 22), max_size=3)))
    dtype = draw(DTYPES)
    a = np.random.default_rng(draw(st.integers(0, 2**16))).normal(size=shape)
    for value, index in draw(st.lists(st.tuples(SPECIAL, st.integers(0, 10**6)), max_size=3)):
        if a.size:
            a.flat[index % a.size] = value
    with np.errstate(all="ignore"):
        if dtype[0] in "US":
            return a.astype(dtype)
        if np.dtype(dtype).kind in "iub":
            a = np.nan_to_num(a, posinf=0, neginf=0).clip(-100, 100)
        return a.astype(dtype)


def _archive(members: dict[str, np.ndarray], meta: str | None, version: object) -> bytes:
    buf = io.BytesIO()
    payload = dict(members)
    if meta is not None:
        payload["meta"] = np.asarray(meta)
    if version is not None:
        payload["format_version"] = np.asarray(version)
    np.savez(buf, **payload)
    return buf.getvalue()


@FUZZ
@given(
    kind=st.sampled_from(KINDS),
    members=st.dictionaries(
        st.sampled_from(["t", "position", "mean", "q", "gripper", "valid", "cov", "x", "tau"]),
        arrays(),
        max_size=6,
    ),
    meta_kind=st.sampled_from([*KINDS, "other", None]),
    version=st.sampled_from([1, 0, 2, -1, 10**6, "1", 1.5, None]),
)
def test_random_archives(tmp_path: Path, kind, members, meta_kind, version) -> None:
    meta = None if meta_kind is None else json.dumps({"kind": meta_kind})
    path = tmp_path / "a.npz"
    path.write_bytes(_archive(members, meta, version))
    _load_or_invalid(kind, path)


@FUZZ
@given(
    kind=st.sampled_from(KINDS),
    victim=st.integers(0, 20),
    replacement=arrays(),
    how=st.sampled_from(["replace", "special", "scale", "dtype", "drop", "transpose"]),
    special=SPECIAL,
    index=st.integers(0, 10**6),
)
def test_valid_file_with_one_array_mutated(tmp_path, kind, victim, replacement, how, special,
                                           index) -> None:  # fmt: skip
    src = tmp_path / "src.npz"
    src.write_bytes(_valid_bytes(kind, tmp_path))
    with np.load(src, allow_pickle=False) as data:
        members = {k: data[k] for k in data.files}
    names = sorted(k for k in members if k not in ("meta", "format_version"))
    name = names[victim % len(names)]
    a = members[name]
    with np.errstate(all="ignore"):
        if how == "replace":
            members[name] = replacement
        elif how == "special" and a.size and a.dtype.kind == "f":
            a = a.copy()
            a.flat[index % a.size] = special
            members[name] = a
        elif how == "scale" and a.dtype.kind == "f":
            members[name] = a * special
        elif how == "dtype":
            members[name] = a.astype(np.float32 if a.dtype.kind != "f" else np.int64)
        elif how == "drop":
            del members[name]
        elif how == "transpose":
            members[name] = a.T
    meta = str(members.pop("meta"))
    version = members.pop("format_version")
    path = tmp_path / "m.npz"
    path.write_bytes(_archive(members, meta, version))
    _load_or_invalid(kind, path)


@pytest.mark.parametrize("kind", KINDS)
def test_pickled_object_arrays_are_never_unpickled(tmp_path: Path, kind: str) -> None:
    class Boom:
        def __reduce__(self):
            return (pytest.fail, ("unpickled a payload",))

    src = tmp_path / "src.npz"
    src.write_bytes(_valid_bytes(kind, tmp_path))
    with np.load(src, allow_pickle=False) as data:
        members = {k: data[k] for k in data.files}
    for name in ("t", "meta"):
        evil = dict(members)
        evil[name] = np.array([Boom()], dtype=object)
        path = tmp_path / f"evil_{name}.npz"
        np.savez(path, **evil)
        assert _load_or_invalid(kind, path) is None
        with pytest.raises(InvalidFile):
            load_any(path)


@FUZZ
@given(
    kind=st.sampled_from(KINDS),
    extra=st.dictionaries(
        st.one_of(st.from_regex(r"[a-z_]{1,8}", fullmatch=True), st.sampled_from(["t", "meta"])),
        arrays(),
        max_size=3,
    ),
)
def test_zip_with_foreign_members_and_names(tmp_path: Path, kind: str, extra) -> None:
    src = tmp_path / "src.npz"
    src.write_bytes(_valid_bytes(kind, tmp_path))
    path = tmp_path / "z.npz"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(path, "w") as zout:
        replaced = {f"{key}.npy" for key in extra}
        for item in zin.infolist():
            if item.filename not in replaced:
                zout.writestr(item, zin.read(item.filename))
        for key, arr in extra.items():
            buf = io.BytesIO()
            np.save(buf, arr, allow_pickle=False)
            zout.writestr(f"{key}.npy", buf.getvalue())
    _load_or_invalid(kind, path)
