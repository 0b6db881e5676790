from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest

from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io import (
    Demonstration,
    LearnedModel,
    Plan,
    Rollout,
    load_demonstration,
    load_model,
    load_plan,
    load_rollout,
    save_demonstration,
    save_model,
    save_plan,
    save_rollout,
)


def _plan(n: int = 5) -> Plan:
    z = np.zeros((n, 3))
    q = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    return Plan(
        t=np.arange(n) * 0.1,
        position=z,
        velocity=z,
        acceleration=z,
        quaternion=q,
        angular_velocity=z,
        gripper=np.full(n, 0.04),
    )


def _model(m: int = 4, k: int = 2) -> LearnedModel:
    mean = np.zeros((m, 8))
    mean[:, 6] = 1.0
    return LearnedModel(
        t=np.linspace(0, 1, m),
        mean=mean,
        cov=np.tile(np.eye(8), (m, 1, 1)),
        gmm_weights=np.full(k, 1 / k),
        gmm_means=np.zeros((k, 9)),
        gmm_covs=np.tile(np.eye(9), (k, 1, 1)),
    )


def _rollout(n: int = 3) -> Rollout:
    q = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    return Rollout(
        t=np.arange(n) * 1e-3,
        q=np.zeros((n, 7)),
        dq=np.zeros((n, 7)),
        tau=np.zeros((n, 7)),
        ee_position=np.zeros((n, 3)),
        ee_quaternion=q,
        ref_position=np.zeros((n, 3)),
        ref_quaternion=q,
        gripper=np.zeros(n),
        meta={"controller": "pd"},
    )


def test_demonstration_round_trip_keeps_nan_and_extras(tmp_path: Path, demos) -> None:
    d = demos[0]
    valid = d.valid.copy()
    valid[3:5] = False
    pos = d.position.copy()
    pos[3:5] = np.nan
    quat = d.quaternion.copy()
    quat[3:5] = np.nan
    grip = d.gripper.copy()
    grip[3:5] = np.nan
    demo = Demonstration(
        t=d.t,
        keypoints=d.keypoints,
        valid=valid,
        position=pos,
        quaternion=quat,
        gripper=grip,
        grasp=d.grasp,
        meta=d.meta,
        extras={"confidence": np.ones(d.n_samples)},
    )
    save_demonstration(tmp_path / "d.npz", demo)
    back = load_demonstration(tmp_path / "d.npz")
    np.testing.assert_array_equal(back.position, demo.position)
    np.testing.assert_array_equal(back.valid, valid)
    np.testing.assert_array_equal(back.extras["confidence"], np.ones(d.n_samples))
    assert back.meta["source"] == "synthetic"
    assert back.meta["kind"] == "demonstration"


@pytest.mark.parametrize(
    ("obj", "save", "load"),
    [
        (_plan(), save_plan, load_plan),
        (_model(), save_model, load_model),
        (_rollout(), save_rollout, load_rollout),
    ],
)
def test_round_trips(tmp_path: Path, obj, save, load) -> None:
    path = save(tmp_path / "x.npz", obj)
    back = load(path)
    for name in obj.SPECS:
        np.testing.assert_array_equal(getattr(back, name), getattr(obj, name))
    with np.load(path, allow_pickle=False) as raw:  # readable without dexlfd
        assert json.loads(str(raw["meta"]))["kind"] == obj.KIND
        assert int(raw["format_version"]) == obj.VERSION
    # a rollout's members are stored (1 kHz floats hardly deflate), the others deflated
    with zipfile.ZipFile(path) as zf:
        methods = {i.compress_type for i in zf.infolist()}
    want = zipfile.ZIP_STORED if isinstance(obj, Rollout) else zipfile.ZIP_DEFLATED
    assert methods == {want}


def test_wrong_kind_names_file_and_kinds(tmp_path: Path) -> None:
    save_plan(tmp_path / "p.npz", _plan())
    with pytest.raises(InvalidFile, match=r"p\.npz.*'plan' file, expected a 'model'"):
        load_model(tmp_path / "p.npz")


def test_missing_truncated_and_foreign_files(tmp_path: Path) -> None:
    with pytest.raises(InvalidFile, match="no such file"):
        load_plan(tmp_path / "nope.npz")
    path = save_plan(tmp_path / "p.npz", _plan())
    data = path.read_bytes()
    (tmp_path / "trunc.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(InvalidFile, match=r"trunc\.npz.*not a readable"):
        load_plan(tmp_path / "trunc.npz")
    np.savez(tmp_path / "foreign.npz", a=np.zeros(3))
    with pytest.raises(InvalidFile, match="not a dexlfd file"):
        load_plan(tmp_path / "foreign.npz")
    (tmp_path / "text.npz").write_text("hello")
    with pytest.raises(InvalidFile, match="not a readable"):
        load_plan(tmp_path / "text.npz")


def test_pickled_object_arrays_are_refused(tmp_path: Path) -> None:
    meta = json.dumps({"kind": "plan"})
    np.savez(
        tmp_path / "obj.npz", format_version=1, meta=meta, t=np.array([object()], dtype=object)
    )
    with pytest.raises(InvalidFile, match="not a readable"):
        load_plan(tmp_path / "obj.npz")


def test_future_version_and_bad_shape(tmp_path: Path) -> None:
    p = _plan()
    arrays = {n: getattr(p, n) for n in p.SPECS if getattr(p, n) is not None}
    np.savez(tmp_path / "v9.npz", format_version=9, meta=json.dumps({"kind": "plan"}), **arrays)
    with pytest.raises(InvalidFile, match="format_version 9"):
        load_plan(tmp_path / "v9.npz")
    arrays["velocity"] = np.zeros((5, 2))
    np.savez(tmp_path / "bad.npz", format_version=1, meta=json.dumps({"kind": "plan"}), **arrays)
    with pytest.raises(InvalidFile, match=r"bad\.npz.*'velocity'.*shape"):
        load_plan(tmp_path / "bad.npz")


def test_nan_outside_mask_is_rejected() -> None:
    p = _plan()
    pos = np.array(p.position)
    pos[1, 0] = np.nan
    with pytest.raises(InvalidInput, match="'position' contains NaN"):
        Plan(
            t=p.t,
            position=pos,
            velocity=p.velocity,
            acceleration=p.acceleration,
            quaternion=p.quaternion,
            angular_velocity=p.angular_velocity,
            gripper=p.gripper,
        )


def test_demonstration_nan_must_match_valid(demos) -> None:
    d = demos[0]
    pos = d.position.copy()
    pos[0] = np.nan
    with pytest.raises(InvalidInput, match="NaN at sample 0, where valid is true"):
        Demonstration(
            t=d.t,
            keypoints=d.keypoints,
            valid=d.valid,
            position=pos,
            quaternion=d.quaternion,
            gripper=d.gripper,
            grasp=d.grasp,
        )


def test_atomic_write_keeps_old_file_on_failure(tmp_path: Path, monkeypatch) -> None:
    path = save_plan(tmp_path / "p.npz", _plan(5))
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "savez_compressed", boom)
    with pytest.raises(InvalidFile, match="No space left"):
        save_plan(path, _plan(7))
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["p.npz"]  # no temporary left behind


def test_arrays_are_read_only_and_inputs_not_aliased() -> None:
    p = _plan()
    with pytest.raises(ValueError, match="read-only"):
        p.position[0, 0] = 1.0


def test_zip_with_pickle_header_is_not_loaded(tmp_path: Path) -> None:
    with zipfile.ZipFile(tmp_path / "z.npz", "w") as zf:
        zf.writestr("meta.npy", b"garbage")
    with pytest.raises(InvalidFile):
        load_plan(tmp_path / "z.npz")
