"""The dataset card (``README.md``) of an exported LeRobot dataset.

What a LeRobot user reads first, as the Hugging Face hub shows it: a YAML header
(``license``, ``task_categories``, ``tags``, ``configs`` pointing at the parquet
files) and a body saying what the episodes are (demonstrations tracked from video,
or simulated rollouts), their rate, tasks and features with units, and the
``info.json`` excerpt LeRobot's own cards carry.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from dexlfd import __version__
from dexlfd.io.demonstration import Demonstration
from dexlfd.io.rollout import Rollout

__all__ = ["dataset_card"]

_UNITS = {
    "observation.state": "x, y, z [m] (base frame), qx..qw (unit quaternion), gripper "
    "opening [m]; rollouts add panda_joint1..7 [rad]",
    "action": "the commanded (demonstrations: recorded) pose and gripper, as the state",
    "observation.velocity": "panda_joint1..7 [rad/s]",
    "observation.effort": "panda_joint1..7 [N m]",
    "observation.hand_keypoints": "21 hand landmarks x, y, z [m] (MediaPipe order)",
    "observation.hand_visible": "whether the hand was seen in this frame",
    "observation.grasp": "whether the hand was grasping",
    "observation.images.camera": "the recording's camera, H.264 MP4",
}


def _origin(record: Demonstration | Rollout) -> str:
    if isinstance(record, Rollout):
        name = record.controller
        return f"simulated rollout ({name or 'controller'})"
    source = record.meta.get("source")
    if source == "synthetic":
        return "synthetic demonstration"
    quality = record.quality
    if quality is not None:
        return "recorded demonstration, " + ("usable" if quality.usable else "NOT USABLE")
    return "demonstration"


def dataset_card(
    info: dict[str, Any],
    records: Sequence[Demonstration | Rollout],
    tasks: Sequence[str],
    names: Sequence[str],
    is_demo: bool,
) -> str:
    """The card's Markdown for a dataset of ``records`` with ``info`` (``meta/info.json``)."""
    kind = "demonstrations" if is_demo else "rollouts"
    rows = [
        f"| {i} | {name or '-'} | {_origin(r)} | {task} |"
        for i, (r, name, task) in enumerate(zip(records, names, tasks, strict=True))
    ]
    features = [
        f"- `{k}`: {_UNITS[k]}" for k in info["features"] if k in _UNITS
    ]  # the default columns (index, timestamp, ...) are LeRobot's own
    what = (
        "Human hand demonstrations turned into end-effector motion by dexlfd's capture "
        "and motion stages (MediaPipe hand landmarks; depth from a lifting model)."
        if is_demo
        else "Simulated Franka Panda rollouts (MuJoCo, 1 kHz torque control) of a plan "
        "learned from demonstrations, resampled to the dataset's rate."
    )
    keys = ("codebase_version", "robot_type", "fps", "total_episodes", "total_frames",
            "total_tasks")  # fmt: skip
    info_excerpt = {k: info[k] for k in keys}
    return "\n".join([
        "---",
        "license: mit",
        "task_categories:",
        "- robotics",
        "tags:",
        "- LeRobot",
        "- dexlfd",
        "- franka-panda",
        f"- {kind}",
        "configs:",
        "- config_name: default",
        "  data_files: data/*/*.parquet",
        "---",
        "",
        f"# dexlfd {kind}",
        "",
        f"{what} Written by dexlfd {__version__} as a LeRobotDataset "
        f"{info['codebase_version']}: {info['total_episodes']} episode(s), "
        f"{info['total_frames']} frames at {info['fps']} fps, robot type "
        f"`{info['robot_type']}`.",
        "",
        "## Episodes",
        "",
        "| episode | source | what it is | task |",
        "|---|---|---|---|",
        *rows,
        "",
        "## Features",
        "",
        *features,
        "",
        "Units are SI; poses are in the Panda's base frame (`panda_link0`). Each episode "
        "row of `meta/episodes` also holds dexlfd's own `dexlfd/meta` (JSON).",
        "",
        "## meta/info.json",
        "",
        "```json",
        json.dumps(info_excerpt, indent=2),
        "```",
        "",
    ])  # fmt: skip
