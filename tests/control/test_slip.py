"""carry_slip: the object's slide in the hand while carried, not at the set-down."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.control.slip import carry_slip
from dexlfd.io import Rollout


def _rollout(p_obj: np.ndarray, p_tcp: np.ndarray, attached: np.ndarray) -> Rollout:
    n = p_obj.shape[0]
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))  # TCP turned 180 deg about x: z down
    zeros7 = np.zeros((n, 7))
    return Rollout(
        t=np.arange(n) * 1e-3, q=zeros7, dq=zeros7, tau=zeros7, ee_position=p_tcp,
        ee_quaternion=quat, ref_position=p_tcp, ref_quaternion=quat, gripper=np.zeros(n),
        extras={"payload_position": p_obj, "attached": attached},
    )  # fmt: skip


def test_slip_is_the_slide_in_the_tcp_frame_during_the_carry_only() -> None:
    n = 400
    z = np.concatenate([np.zeros(50), np.linspace(0, 0.2, 100), np.full(100, 0.2),
                        np.linspace(0.2, 0, 100), np.zeros(50)])  # fmt: skip
    p_tcp = np.column_stack([np.zeros(n), np.zeros(n), 0.3 + z])
    slide = np.clip((np.arange(n) - 150) / 100, 0, 1) * 0.005  # 5 mm down the hand's x
    p_obj = p_tcp + np.column_stack([slide, np.zeros(n), np.zeros(n)])
    p_obj[-50:, 2] += 0.003  # set down: the support pushes it 3 mm up the hand (not slip)
    ro = _rollout(p_obj, p_tcp, np.ones(n, bool))
    assert carry_slip(ro) == pytest.approx(0.005, abs=1e-9)
    assert carry_slip(_rollout(p_obj, p_tcp, np.zeros(n, bool))) is None  # never held


def test_never_lifted_has_no_slip() -> None:
    n = 50
    p = np.tile([0.4, 0.0, 0.1], (n, 1))
    assert carry_slip(_rollout(p, p, np.ones(n, bool))) is None


def test_an_object_held_still_while_the_hand_tilts_does_not_slip() -> None:
    from dexlfd.rotations import matrix_from_quat

    n = 200
    tilt = np.linspace(0.0, np.pi / 2, n)  # the hand tilts 90 deg about the world x
    quat = np.column_stack([np.sin(tilt / 2), np.zeros(n), np.zeros(n), np.cos(tilt / 2)])
    R = matrix_from_quat(quat)
    p_tcp = np.column_stack(
        [np.full(n, 0.4), np.zeros(n), 0.3 + 0.1 * np.sin(np.pi * np.arange(n) / (n - 1))]
    )
    p_obj = p_tcp + np.einsum("kij,j->ki", R, [0.01, 0.02, 0.0])  # fixed in the hand
    ro = _rollout(p_obj, p_tcp, np.ones(n, bool))
    ro = dataclasses.replace(ro, ee_quaternion=quat)
    assert carry_slip(ro) == pytest.approx(0.0, abs=1e-12)
