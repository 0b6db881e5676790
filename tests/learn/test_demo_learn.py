from __future__ import annotations

from pathlib import Path

import pytest

from dexlfd.experiments.demo import DemoConfig, run_demo
from dexlfd.io import load_model


@pytest.mark.integration
def test_demo_learns_and_writes_model_and_figures(tmp_path: Path) -> None:
    result = run_demo(DemoConfig(seed=1, n_demos=4), tmp_path)
    model = load_model(tmp_path / "model.npz")
    assert model.meta["n_demonstrations"] == 4 and model.extras["aligned"].shape[0] == 4
    assert result.summary["reference"] == model.meta["reference"]
    for name in ("alignment", "dtw_correspondence", "dtw_example", "gmm", "gmr", "quality"):
        assert (tmp_path / "figures" / f"{name}.png").is_file()
