from __future__ import annotations

import numpy as np
import pytest

from dexlfd.datasets import PickPlaceConfig, pick_place_demonstrations
from dexlfd.errors import InvalidInput


def test_demonstrations_are_varied_valid_and_labelled(demos) -> None:
    lengths = [d.n_samples for d in demos]
    assert len(set(lengths)) == len(demos)
    assert min(lengths) >= 150 and max(lengths) <= 300
    for d in demos:
        assert d.meta["source"] == "synthetic"
        np.testing.assert_allclose(np.linalg.norm(d.quaternion, axis=1), 1.0, atol=1e-12)
        assert (np.einsum("ij,ij->i", d.quaternion[1:], d.quaternion[:-1]) > 0).all()
        assert d.grasp.any() and not d.grasp.all()
        # the object is lifted over the cup: >= 0.25 m above the pick height
        assert d.position[:, 2].max() - 0.12 > 0.25


def test_same_seed_is_bit_identical() -> None:
    a = pick_place_demonstrations(3, np.random.default_rng(7))
    b = pick_place_demonstrations(3, np.random.default_rng(7))
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.pose, y.pose)


def test_bad_config() -> None:
    with pytest.raises(InvalidInput, match="warp_strength"):
        PickPlaceConfig(warp_strength=0.7)
    with pytest.raises(InvalidInput, match="n_demos"):
        pick_place_demonstrations(0, np.random.default_rng(0))
