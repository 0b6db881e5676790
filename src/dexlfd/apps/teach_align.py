"""``teach``'s frame stage: each source's task frame, then every demonstration in the base frame.

Reads the record stage's demonstrations (a folder per source), refuses a source
without any pick-and-place (naming it, its frames and why), estimates the task frame
of each camera from its own pick-and-places (or takes the base frame of calibrated
recordings), decides the robot's pick and place, and writes:

- ``demos_base/<source>-<k>.npz``: every pick-and-place in the robot's base frame;
- ``task_frame.json``: each source's frame, the transforms and the pick and place;
- ``figures/demonstrations_task.png``: the demonstrations in the task frame.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd.errors import InvalidInput
from dexlfd.io import Demonstration, atomic_write

if TYPE_CHECKING:
    from dexlfd.apps.teach import TeachConfig
    from dexlfd.motion.task_frame import TaskFrame

__all__ = ["align_sources", "frame_summary"]

logger = logging.getLogger(__name__)


def _pick_and_places(out: Path, source: dict[str, Any]) -> tuple[list[Demonstration], list[str]]:
    """The source's demonstrations that hold a pick-and-place, and their file names."""
    from dexlfd.io import load_demonstration

    demos, names = [], []
    for rel, frames in zip(source["demonstrations"], source["pick_and_places"], strict=True):
        if frames is not None:
            demos.append(load_demonstration(out / rel))
            names.append(str(rel))
    return demos, names


_GENERIC_SOURCES = ("", "synthetic", "capture", "unknown")  # names no camera


def _camera_groups(
    members: list[tuple[str, Demonstration, str]],
) -> list[tuple[str, list[Demonstration], list[str]]]:
    """The demonstrations of each camera together, calibrated apart from uncalibrated.

    ``members`` are ``(source, demonstration, file)``. A recording's pick-and-places are
    one camera's; demonstration files given as sources are grouped by the recording
    they name (``meta["source"]``), each alone when it names none.
    """
    from dexlfd.apps.teach_frame import is_calibrated

    groups: dict[tuple[str, bool], tuple[list[Demonstration], list[str]]] = {}
    for source, demo, name in members:
        recording = str(demo.meta.get("source", ""))
        camera = source if recording in _GENERIC_SOURCES else recording
        key = (camera, is_calibrated(demo))
        groups.setdefault(key, ([], []))
        groups[key][0].append(demo)
        groups[key][1].append(name)
    return [(Path(cam).name + (" (calibrated)" if cal else ""), d, n)
            for (cam, cal), (d, n) in groups.items()]  # fmt: skip


def _frame_of(demos: list[Demonstration], names: list[str]) -> TaskFrame:
    from dexlfd.apps.teach_frame import frame_of_calibrated, is_calibrated
    from dexlfd.motion.task_frame import estimate_task_frame

    if is_calibrated(demos[0]):
        return frame_of_calibrated(demos, names)
    return estimate_task_frame(demos, names=names)


def frame_summary(frame: TaskFrame) -> dict[str, Any]:
    """The JSON-able part of a task frame ``teach.json`` reports."""
    return {
        "method": frame.method,
        "up_camera": [round(float(v), 5) for v in frame.up_camera],
        "scale": round(float(frame.scale), 5),
        "uncertainty": {k: round(float(v), 5) for k, v in frame.uncertainty.items()},
        "n_events": int(frame.n_events),
    }


def _refuse_without_pick_and_place(cfg: TeachConfig, out: Path, sources: list[dict]) -> None:
    from dexlfd.apps.teach_sources import source_verdicts

    bad = [s for s in sources if not any(f is not None for f in s["pick_and_places"])]
    if not bad:
        return
    lines = []
    for s in bad:
        from dexlfd.apps.teach_sources import SourceRecord
        from dexlfd.io import load_demonstration

        rec = SourceRecord(
            s["source"],
            s["name"],
            n_frames=s["n_frames"],
            demos=[load_demonstration(out / r) for r in s["demonstrations"]],
        )
        lines += source_verdicts([rec])  # fmt: skip
    raise InvalidInput("; ".join(lines) + ": no plan (every source must show the task)")


def align_sources(
    cfg: TeachConfig, out: Path, sources: Sequence[dict[str, Any]]
) -> tuple[dict[str, Path], dict[str, Any]]:
    """The frame stage (module docstring); returns its outputs and summary."""
    from dexlfd.apps.teach_frame import is_calibrated, placement_targets, task_to_base
    from dexlfd.motion.task_frame import apply_frame

    _refuse_without_pick_and_place(cfg, out, list(sources))
    found = []
    for source in sources:
        demos, names = _pick_and_places(out, source)
        found += [(source["source"], d, n) for d, n in zip(demos, names, strict=True)]
    members = []  # (group label, frame, demos, names)
    for label, g_demos, g_names in _camera_groups(found):
        frame = _frame_of(g_demos, g_names)
        logger.info(
            "%s: task frame by %s from %d pick-and-place(s): up %s (camera), scale %.3f, "
            "uncertainty %s", label, frame.method, len(g_demos),
            np.round(frame.up_camera, 3).tolist(), frame.scale,
            {k: round(float(v), 3) for k, v in frame.uncertainty.items()},
        )  # fmt: skip
        members.append((label, frame, g_demos, g_names))
    task_demos = [apply_frame(d, f.camera_to_task, f.scale, frame_name="task")
                  for _, f, ds, _ in members for d in ds]  # fmt: skip
    all_names = [n for *_, ns in members for n in ns]
    calibrated = all(is_calibrated(d) for _, _, ds, _ in members for d in ds)
    calibrated_pick = None
    if calibrated:  # the demonstrated pick, where it was, in the base frame
        calibrated_pick = np.mean([-f.camera_to_task[:3, 3] for _, f, _, _ in members], axis=0)
    placement = placement_targets(
        task_demos, all_names, pick=cfg.pick, place=cfg.place, object_size=cfg.object_size,
        calibrated_pick=calibrated_pick,
    )  # fmt: skip
    T_tb = task_to_base(placement.pick)
    folder = out / "demos_base"
    folder.mkdir(exist_ok=True)
    for stale in folder.glob("*.npz"):
        stale.unlink()
    outputs: dict[str, Path] = {}
    demonstrations = []
    for _, frame, g_demos, g_names in members:
        camera_to_base = T_tb @ frame.camera_to_task
        for demo, name in zip(g_demos, g_names, strict=True):
            moved = apply_frame(demo, camera_to_base, frame.scale, frame_name="panda_base")
            path = folder / Path(name).name
            outputs[f"demo_{path.stem}"] = _save(path, moved)
            demonstrations.append(str(path.relative_to(out)))
    frames = [
        {"group": label, "demonstrations": names, **frame_summary(frame),
         "camera_to_task": np.round(frame.camera_to_task, 6).tolist()}
        for label, frame, _, names in members
    ]  # fmt: skip
    summary = {
        "frames": frames,
        "task_to_base": np.round(T_tb, 6).tolist(),
        "placement": placement.to_dict(),
        "demonstrations": demonstrations,
    }
    data = json.dumps(summary, indent=2).encode()
    atomic_write(out / "task_frame.json", lambda fh: fh.write(data))
    outputs["task_frame"] = out / "task_frame.json"
    return outputs, summary


def _save(path: Path, demo: Demonstration) -> Path:
    from dexlfd.io import save_demonstration

    return save_demonstration(path, demo)
