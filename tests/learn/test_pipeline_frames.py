from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.learn import LearnConfig, learn_from_demonstrations


def test_demonstrations_in_different_frames_are_refused(demos) -> None:
    mixed = [dataclasses.replace(demos[0], frame="camera"), *demos[1:]]
    with pytest.raises(InvalidInput, match="different frames"):
        learn_from_demonstrations(mixed, LearnConfig(), np.random.default_rng(0))


def test_the_model_records_the_frame(demos) -> None:
    model = learn_from_demonstrations(demos[:3], LearnConfig(), np.random.default_rng(0)).model
    assert model.frame == "panda_base"
