"""The tracking figure of a 1 kHz rollout: drawn from fewer samples, its spikes kept."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dexlfd.io import Rollout


def _rollout_with_spikes(seconds: float = 20.0) -> Rollout:
    """A 1 kHz rollout with a one-sample spike in the tracking error and in joint 2's torque."""
    rng = np.random.default_rng(5)
    t = np.arange(0.0, seconds, 1e-3)
    ref = np.column_stack([0.4 + 0.1 * np.sin(t / 3), -0.3 + 0.02 * t, 0.2 + 0.1 * np.cos(t)])
    p = ref + 1e-3 * rng.normal(size=ref.shape)
    p[int(0.617 * t.size), 2] += 0.05  # 50 mm for one sample
    tau = np.column_stack([np.sin(t + j) + 0.3 * rng.normal(size=t.size) for j in range(7)])
    tau[int(0.438 * t.size), 1] = 40.0
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (t.size, 1))
    return Rollout(t=t, q=np.zeros((t.size, 7)), dq=np.zeros((t.size, 7)), tau=tau,
                   ee_position=p, ee_quaternion=quat, ref_position=ref, ref_quaternion=quat,
                   gripper=np.full(t.size, 0.04), controller="ntsm-pd", payload_kg=0.3,
                   extras={"orientation_error": np.radians(1.0 + 0.1 * np.sin(t))})  # fmt: skip


def test_rollout_figure_draws_fewer_samples_and_keeps_the_spikes(tmp_path, monkeypatch) -> None:
    from PIL import Image

    import dexlfd.viz.control as control

    rollout = _rollout_with_spikes()
    drawn: list = []
    save = control.save_figure

    def keep_lines(fig, path, *args, **kwargs):  # type: ignore[no-untyped-def]
        drawn.extend([[line.get_xydata() for line in ax.get_lines()] for ax in fig.axes])
        return save(fig, path, *args, **kwargs)

    monkeypatch.setattr(control, "save_figure", keep_lines)
    path = control.plot_rollout(rollout, tmp_path / "rollout.png")
    with Image.open(path) as im:
        im.verify()
    position, error, _, torque = drawn
    n = rollout.t.size
    assert len(position) == 6 and len(torque) == 7  # actual and desired x, y, z; 7 joints
    for line in position + error + torque:
        assert len(line) < n / 4  # ~2 samples a half pixel column, not 20 000
        assert line[0, 0] == rollout.t[0] and line[-1, 0] == rollout.t[-1]
    err = 1e3 * np.linalg.norm(rollout.ee_position - rollout.ref_position, axis=1)
    assert error[0][:, 1].max() == err.max() > 40.0  # the one-sample error spike
    assert torque[1][:, 1].max() == 40.0  # joint 2's spike
    for j, line in enumerate(torque):  # each curve spans what all its samples span
        assert line[:, 1].min() == rollout.tau[:, j].min()
        assert line[:, 1].max() == rollout.tau[:, j].max()


def test_rollout_figure_keeps_a_short_rollout_whole(tmp_path: Path, monkeypatch) -> None:
    import dexlfd.viz.control as control

    rollout = _rollout_with_spikes(seconds=1.0)  # 1000 samples: fewer than the columns
    drawn: list = []
    monkeypatch.setattr(control, "save_figure",
                        lambda fig, path, **kw: drawn.append(fig.axes[3].get_lines()))  # fmt: skip
    control.plot_rollout(rollout, tmp_path / "rollout.png")
    assert [len(line.get_xdata()) for line in drawn[0]] == [rollout.t.size] * 7
