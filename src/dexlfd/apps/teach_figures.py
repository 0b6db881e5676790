"""``teach``'s figures of the demonstrations, the model and the plan, drawn off the critical path.

Each takes about 0.4 s of CPU (matplotlib); drawn by the stages that make their data,
the three held up the simulation by about 1.2 s. Two background stages draw them from
the files the earlier stages wrote: ``figures`` (:func:`draw_figures`: the
demonstrations and the model) while the plan is made, which leaves the second core
idle, and ``plan_figure`` (:func:`draw_plan_figure`) while the simulation runs:

- ``figures/demos_task.png``: the demonstrations in the task frame (the ones in the
  robot's base frame, ``demos_base/``, moved back by the inverse of ``task_to_base``);
- ``figures/model.png``: the GMR of the learned model (learning is seeded: it is learned
  again from the same demonstrations, the same trajectory as the learn stage's);
- ``figures/plan.png``: the plan with the object and its supports.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from dexlfd.apps.teach import TeachConfig
    from dexlfd.io import Demonstration

__all__ = ["draw_figures", "draw_plan_figure", "learn_demonstrations"]


def learn_demonstrations(cfg: TeachConfig, out: Path, names: list[str]) -> tuple[Any, list[Any]]:
    """The learning result of the demonstrations ``names`` (under ``out``), and them.

    Seeded by ``cfg.seed``: the learn stage and the figure learn the same model.
    """
    from dexlfd.io import load_demonstration
    from dexlfd.learn import learn_from_demonstrations

    demos = [load_demonstration(out / n) for n in names]
    learned = learn_from_demonstrations(
        demos, cfg.learn, np.random.default_rng([cfg.seed, 1]), names=names
    )
    return learned, demos


def task_frame_demos(demos: list[Demonstration], task_to_base: Any) -> list[Demonstration]:
    """The base-frame ``demos`` in the task frame (the inverse of ``task_to_base``, 4x4)."""
    from dexlfd.motion.task_frame import apply_frame

    base_to_task = np.linalg.inv(np.asarray(task_to_base, dtype=float))
    return [apply_frame(d, base_to_task, 1.0, frame_name="task") for d in demos]


def draw_figures(
    cfg: TeachConfig, out: Path, frame: dict[str, Any]
) -> tuple[dict[str, Path], dict[str, Any]]:
    """The ``figures`` stage: the demonstrations (task frame) and the model as PNGs."""
    from dexlfd.viz.demonstrations import plot_demonstrations
    from dexlfd.viz.learning import plot_gmr

    summary = frame["summary"]
    folder = out / "figures"
    folder.mkdir(exist_ok=True)
    with _quiet("dexlfd.learn"):  # the learn stage has said it all
        learned, demos = learn_demonstrations(cfg, out, list(summary["demonstrations"]))
    outputs = {
        "fig_demos": plot_demonstrations(
            task_frame_demos(demos, summary["task_to_base"]), folder / "demos_task.png"
        ),
        "fig_model": plot_gmr(learned.trajectory, folder / "model.png"),
    }
    return outputs, {}


def draw_plan_figure(out: Path, frame: dict[str, Any]) -> tuple[dict[str, Path], dict[str, Any]]:
    """The ``plan_figure`` stage: the plan with the object and its supports as a PNG."""
    from dexlfd.io import load_model, load_plan
    from dexlfd.viz.teach import plot_task_plan

    folder = out / "figures"
    folder.mkdir(exist_ok=True)
    size = tuple(float(v) for v in frame["summary"]["placement"]["object_size"])
    path = plot_task_plan(
        load_model(out / "model.npz"), load_plan(out / "plan.npz"), size, folder / "plan.png"
    )
    return {"fig_plan": path}, {}


@contextlib.contextmanager
def _quiet(name: str) -> Iterator[None]:
    """Logger ``name`` (and those under it) says nothing within."""
    log = logging.getLogger(name)
    level = log.level
    log.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        log.setLevel(level)
