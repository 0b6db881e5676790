"""The control, learning and capture figures keep their legends off the plotted data
(and the 3-D hand its axis labels off the tick labels)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.io import Rollout


@pytest.fixture
def checked(monkeypatch, legend_overlaps, label_overlaps_3d):
    """Patch a module's figure writer: each figure is checked before it is saved.

    The problems found per file name: legends over data, 3-D axis labels over ticks.
    """
    found: dict[str, list[str]] = {}

    def patch(module, name: str = "save_figure") -> dict[str, list[str]]:
        save = getattr(module, name)

        def check_then_save(fig, path, *args, **kwargs):
            found[Path(path).name] = legend_overlaps(fig) + label_overlaps_3d(fig)
            return save(fig, path, *args, **kwargs)

        monkeypatch.setattr(module, name, check_then_save)
        return found

    return patch


def _lift_rollout(seed: int, sag_mm: float = 0.0) -> Rollout:
    """A 10 s rollout like the demo's: down to the pick, over a 0.5 m lift, up at the end."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 10.0, 1001)
    bump = np.exp(-(((t - 5.3) / 0.9) ** 6))
    z_ref = (
        0.12 + 0.15 * np.exp(-((t / 0.8) ** 2)) + 0.38 * bump + 0.17 * (t > 9.5) * (t - 9.5) / 0.5
    )
    ref = np.column_stack([0.4 + 0.05 * (t > 1), -0.3 + 0.06 * t, z_ref])
    p = ref + 1e-3 * rng.normal(0.0, 1.0, ref.shape) - [0.0, 0.0, 1e-3 * sag_mm] * bump[:, None]
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (t.size, 1))
    tau = np.zeros((t.size, 7))
    tau[:, 1] = -30.0 + 8.0 * np.sin(t)  # the shoulder holds the arm up
    tau[:, 3] = 20.0 + 6.0 * bump  # the elbow: the highest curve, over the whole run
    tau[:, 5] = 2.0
    return Rollout(t=t, q=np.zeros((t.size, 7)), dq=np.zeros((t.size, 7)), tau=tau,
                   ee_position=p, ee_quaternion=quat, ref_position=ref, ref_quaternion=quat,
                   gripper=np.full(t.size, 0.04), controller="ntsm-pd", payload_kg=1.2,
                   extras={"orientation_error": np.radians(2.0 * bump)})  # fmt: skip


def test_control_figures(checked, tmp_path: Path) -> None:
    import dexlfd.viz.control as control
    from dexlfd.experiments.payload import PayloadConfig, PayloadResult

    found = checked(control)
    names = ("pd", "sm-pd", "ntsm-pd", "ntsm-pd-dob")
    cfg = PayloadConfig(controllers=names, payloads=(0.0, 1.2))
    rollouts = {
        (c, kg): _lift_rollout(i, sag_mm=10.0 * kg * (i == 0))
        for i, c in enumerate(names)
        for kg in cfg.payloads
    }
    control.plot_payload_lift(PayloadResult(rows=[], rollouts=rollouts, config=cfg),
                              tmp_path / "lift.png")  # fmt: skip
    control.plot_rollout(rollouts[("ntsm-pd", 1.2)], tmp_path / "rollout.png")
    assert found == {"lift.png": [], "rollout.png": []}


def test_generalize_figure_shows_the_table_to_scale(checked, aspect_error, tmp_path) -> None:
    import dexlfd.viz.control as control
    from dexlfd.experiments.generalize import GeneralizeConfig, GeneralizeResult

    axes: list = []
    save = control.save_figure

    def keep_axes(fig, path, *args, **kwargs):
        axes.extend(fig.axes[:-1])  # the last is the colour bar
        return save(fig, path, *args, **kwargs)

    control.save_figure = keep_axes
    try:
        found = checked(control)
        cfg = GeneralizeConfig(n_pairs=2, controllers=("ntsm-pd",), payloads=(1.2,))
        pairs = [(np.array([0.47, -0.45, 0.12]), np.array([0.47, 0.45, 0.12])),
                 (np.array([0.47, -0.05, 0.12]), np.array([0.47, 0.05, 0.12]))]  # fmt: skip
        runs = [
            {"pair": k, "controller": "ntsm-pd", "payload_kg": 1.2,
             "placement": {"success": True, "place_error_m": 0.005, "carried": True}}
            for k in range(2)
        ]  # fmt: skip
        result = GeneralizeResult(config=cfg, pairs=pairs, plans=[{}, {}], runs=runs)
        control.plot_generalize(result, tmp_path / "grid.png")
    finally:
        control.save_figure = save
    assert found == {"grid.png": []}
    assert [aspect_error(ax) for ax in axes] == [None]


def test_learning_figures(checked, demos, tmp_path: Path) -> None:
    import dexlfd.viz.learning as learning
    from dexlfd.learn import LearnConfig, learn_from_demonstrations

    found = checked(learning)
    res = learn_from_demonstrations(demos, LearnConfig(n_components=8), np.random.default_rng(0))
    learning.plot_learning(res, tmp_path)
    assert len(found) == 6
    assert {k: v for k, v in found.items() if v} == {}


def test_capture_figures(checked, tmp_path: Path) -> None:
    import dexlfd.viz.capture as capture
    from dexlfd.datasets import demonstration_with_hand, pick_place_demonstrations

    found = checked(capture, "_save")
    rng = np.random.default_rng(0)
    demo = demonstration_with_hand(pick_place_demonstrations(1, rng)[0], rng)
    capture.save_capture_figures(demo, tmp_path)
    assert found == {"hand_3d.png": [], "motion.png": []}
