"""The meta entries the stages read back are type-checked when a file is loaded."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.errors import InvalidFile
from dexlfd.io import (
    Plan,
    Rollout,
    load_demonstration,
    load_plan,
    load_rollout,
    save_demonstration,
    save_plan,
    save_rollout,
)
from dexlfd.io._meta_schema import META_TYPES

WRONG = {"object": "x", "list": "x", "string": 7, "number": "7", "boolean": "yes"}


def _plan(n: int = 5) -> Plan:
    z = np.zeros((n, 3))
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    return Plan(
        t=np.arange(n) * 0.1, position=z, velocity=z, acceleration=z, quaternion=quat,
        angular_velocity=z, gripper=np.full(n, 0.04),
    )  # fmt: skip


def _rollout(n: int = 5) -> Rollout:
    z7, z3 = np.zeros((n, 7)), np.zeros((n, 3))
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    return Rollout(
        t=np.arange(n) * 1e-3, q=z7, dq=z7, tau=z7, ee_position=z3, ee_quaternion=quat,
        ref_position=z3, ref_quaternion=quat, gripper=np.full(n, 0.04),
    )  # fmt: skip


def _cases():
    for kind in ("demonstration", "plan", "rollout"):
        for key, json_type in META_TYPES[kind].items():
            yield pytest.param(kind, key, json_type, id=f"{kind}-{key}")


@pytest.mark.parametrize(("kind", "key", "json_type"), list(_cases()))
def test_a_meta_entry_of_the_wrong_type_is_one_line(
    tmp_path: Path, demos, kind: str, key: str, json_type: str
) -> None:
    record, save, load = {
        "demonstration": (demos[0], save_demonstration, load_demonstration),
        "plan": (_plan(), save_plan, load_plan),
        "rollout": (_rollout(), save_rollout, load_rollout),
    }[kind]
    path = save(tmp_path / "f.npz", record.__class__(**{**_fields(record), "meta": {}}))
    load(path)  # no entry at all is fine
    bad = record.__class__(**{**_fields(record), "meta": {key: WRONG[json_type]}})
    with pytest.raises(
        InvalidFile, match=rf"f\.npz: meta entry '{key}' must be a JSON {json_type}"
    ):
        load(save(path, bad))


def test_null_tables_and_lists_read_as_absent(tmp_path: Path) -> None:
    plan = _plan()
    path = save_plan(tmp_path / "p.npz", Plan(**{**_fields(plan), "meta": {"settings": None}}))
    assert load_plan(path).meta["settings"] is None


def _fields(record) -> dict:
    from dataclasses import fields

    return {f.name: getattr(record, f.name) for f in fields(record)}
